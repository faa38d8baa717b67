"""Transportation loss: separable-kernel Sinkhorn vs the dense (HW)×(HW) reference, on CPU.

Paper settings (48×48 grid, ε = 0.01, 5 iterations). Prints a markdown table and writes it to the
"Transport loss" section of docs/benchmarks.md.

    python benchmarks/transport.py [--threads N] [--repeats R]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

from nsp.painter.transport import dense_sinkhorn, sinkhorn

sys.path.insert(0, str(Path(__file__).parent))
from doc import best_seconds, machine, write_section  # noqa: E402

GRID, EPS, ITERS = 48, 0.01, 5
BATCHES = (1, 4)


def best_ms(fn, repeats: int) -> float:
    """Milliseconds of the fastest of ``repeats`` timed calls."""
    return 1e3 * best_seconds(fn, repeats)


def run(repeats: int) -> list[str]:
    rows = [
        "| batch | pass | separable (ms) | dense (ms) | speedup | rel. diff |",
        "|---:|---|---:|---:|---:|---:|",
    ]
    for batch in BATCHES:
        torch.manual_seed(batch)
        a = torch.rand(batch, GRID, GRID, requires_grad=True)
        b = torch.rand(batch, GRID, GRID)
        fast, slow = sinkhorn(a, b, EPS, ITERS), dense_sinkhorn(a, b, EPS, ITERS)
        diff = ((fast - slow).abs() / slow).max().item()
        for name, step in [
            ("forward (no grad)", lambda f: f(a, b, EPS, ITERS)),
            ("forward+backward", lambda f: f(a, b, EPS, ITERS).sum().backward()),
        ]:
            with torch.no_grad() if name.startswith("forward (") else torch.enable_grad():
                t_fast = best_ms(lambda: step(sinkhorn), repeats)
                t_slow = best_ms(lambda: step(dense_sinkhorn), max(1, repeats // 4))
            speedup = t_slow / t_fast
            rows.append(f"| {batch} | {name} | {t_fast:.1f} | {t_slow:.0f} | {speedup:.0f}× | {diff:.1e} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=torch.get_num_threads(), help="torch CPU threads")
    parser.add_argument("--repeats", type=int, default=20, help="timed runs of the separable form (dense: ¼)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    rows = run(args.repeats)
    command = " ".join(["python", "benchmarks/transport.py", *sys.argv[1:]])
    body = "\n".join(
        [
            f"Sinkhorn transport cost at {GRID}×{GRID}, ε = {EPS}, {ITERS} iterations (paper settings):",
            "`sinkhorn` (separable kernel, two 1-D log-sum-exp passes per half-iteration) vs",
            "`dense_sinkhorn` (explicit (HW)×(HW) cost matrix), both in `nsp.painter.transport`, float32.",
            "Times are the best of several runs; rel. diff is |separable − dense| / dense.",
            "",
            f"Command: `{command}`  ",
            f"Machine: {machine()}; {time.strftime('%Y-%m-%d')}",
            "",
            *rows,
        ]
    )
    print(body)
    write_section("Transport loss", body)


if __name__ == "__main__":
    main()
