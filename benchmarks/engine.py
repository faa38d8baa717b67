"""Vector engine throughput: strokes/s at 128 px per brush, batch 1 and 256, eager and compiled, CPU (and CUDA).

    python benchmarks/engine.py [--repeats 15]

Each rate is the fastest of ``--repeats`` timed calls after a warm-up (the compile happens in the
warm-up). Prints a markdown table and writes it to the "Vector engine" section of docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

from nsp.brushes import BRUSHES
from nsp.engine import paint_canvas, render
from nsp.engine.raster import clear, rasterize

sys.path.insert(0, str(Path(__file__).parent))
from doc import best_seconds, machine, write_section  # noqa: E402

SIZE, BATCH = 128, 256
CANVAS = 6000  # strokes painted in order by `paint_canvas`, as `nsp.render` does (benchmarks/render.py)


def strokes(name: str, n: int, moderate: bool, device) -> torch.Tensor:
    brush = BRUSHES[name]
    x = brush.sample(n, torch.Generator().manual_seed(0)).to(device)
    if moderate:  # sizes in the lower quarter of their range
        x[:, [i for i, k in enumerate(brush.kinds) if k == "size"]] *= 0.25
    return x


def rates(name: str, moderate: bool, compile: bool, device, repeats: int) -> dict[str, float]:
    """Strokes/s of one brush: batch 1, batch 256 into a reused and a fresh tensor, tiles only, and
    6000 composited onto one canvas (a fifth of the repeats: seconds a call eager)."""
    brush, x, many = BRUSHES[name], strokes(name, BATCH, moderate, device), strokes(name, CANVAS, moderate, device)
    out = torch.empty(BATCH, 4, SIZE, SIZE, device=device)
    sync = torch.cuda.synchronize if device.type == "cuda" else (lambda: None)
    calls = {
        "one": (1, lambda: render(brush, x[:1], SIZE, compile=compile)),
        "reused": (BATCH, lambda: render(brush, x, SIZE, compile=compile, out=out)),
        "fresh": (BATCH, lambda: render(brush, x, SIZE, compile=compile)),
        "tiles": (BATCH, lambda: rasterize(brush, x, SIZE, SIZE, compile=compile)),
        "canvas": (CANVAS, lambda: paint_canvas(brush, many, SIZE, SIZE, compile=compile)),
    }
    return {key: n / best_seconds(lambda: (draw(), sync()), max(1, repeats // 5) if key == "canvas" else repeats)
            for key, (n, draw) in calls.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15, help="timed calls per measurement")
    args = parser.parse_args()
    devices = [torch.device("cpu")] + ([torch.device("cuda")] if torch.cuda.is_available() else [])
    rows = [
        f"| device | brush | sizes | engine | batch 1 | batch {BATCH}, reused `out` | batch {BATCH}, fresh tensor "
        f"| batch {BATCH}, tiles only | {CANVAS:,} on a canvas | × reference |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---|",
    ]
    for device in devices:
        for name in BRUSHES:
            for moderate in (True, False):
                for compile in (False, True):
                    r = rates(name, moderate, compile, device, args.repeats)
                    rows.append(
                        f"| {device.type} | {name} | {'moderate' if moderate else 'uniform'} "
                        f"| {'compiled' if compile else 'eager'} | {r['one']:,.0f} | {r['reused']:,.0f} "
                        f"| {r['fresh']:,.0f} | {r['tiles']:,.0f} | {r['canvas']:,.0f} | not measured |"
                    )
                    print(rows[-1], flush=True)
        out = torch.empty(BATCH, 4, SIZE, SIZE, device=device)
        zero = BATCH / best_seconds(lambda: clear(out), args.repeats)
        rows.append(f"| {device.type} | — | — | clearing `out` alone | | {zero:,.0f} | | | | |")
        print(rows[-1], flush=True)
    body = (
        f"Strokes rendered per second at {SIZE}×{SIZE} (foreground + alpha, antialiased), random strokes:\n"
        "*uniform* over the whole parameter space (what renderer training draws), *moderate* with sizes\n"
        "in the lower quarter of their range (nsp's own choice).\n"
        f"*batch {BATCH}* returns dense ({BATCH}, 4, {SIZE}, {SIZE}) float32 images, into a reused `out=` tensor\n"
        f"or a fresh one (a fresh 67 MB tensor is page-faulted in by the kernel on every call); *tiles only*\n"
        "stops at the sparse (stroke, tile) pixels that `paint_canvas` composites; *6,000 on a canvas* is\n"
        "`paint_canvas` of 6,000 such strokes in order, what `nsp.render` does in process. *compiled* is\n"
        "`render(..., compile=True)` (shading by AOTInductor kernels, `nsp.engine.fused`, compiled before timing:\n"
        "for watercolor, marker pen and tape one kernel of every canvas size, their culling eager; for oil, whose\n"
        "bristles are drawn at this size, culling and shading by kernels of this size). The last row\n"
        "zeroes the dense output and nothing else: memory bandwidth caps any dense renderer there.\n"
        "Rates are the fastest of several timed calls. The reference implementation does not run in this benchmark,\n"
        "so no ratio to it is given here: `benchmarks/render.py --reference PATH` times both on the same strokes.\n\n"
        f"Command: `python benchmarks/engine.py --repeats {args.repeats}`  \nMachine: {machine()}; {time.strftime('%Y-%m-%d')}\n\n"
        + "\n".join(rows)
    )
    write_section("Vector engine", body)


if __name__ == "__main__":
    main()
