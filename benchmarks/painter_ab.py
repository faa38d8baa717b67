"""Painter A/B: this checkout's ``python -m nsp.paint`` against another checkout's, in turn on the same host.

For each photo, the two paint it alternately (A B A B …, ``--repeats`` times each, a fresh process
each time, one painting at a time); a painting's time is metrics.json's ``painting_seconds`` (the
painter alone), its scores the command's own (metrics.json). Prints a row per photo and the means; with ``--section``
writes them as that section of docs/benchmarks.md.

    git worktree add /tmp/base <commit>
    python benchmarks/painter_ab.py --base /tmp/base --strokes 500 [--photos astronaut chelsea] [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402
from painter import paint_once  # noqa: E402

from nsp.images import BUILTIN  # noqa: E402

HERE = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True, help="the other checkout (B): its src/ is imported")
    parser.add_argument("--photos", nargs="+", default=list(BUILTIN))
    parser.add_argument("--brush", default="oilpaint")
    parser.add_argument("--strokes", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=3, help="paintings of each photo by each checkout")
    parser.add_argument("--section", help="write the table as this section of docs/benchmarks.md")
    parser.add_argument("--date", default=time.strftime("%Y-%m-%d"))
    args = parser.parse_args()
    sides = {"A": HERE / "src", "B": args.base.resolve() / "src"}
    rows = ["| photo | PSNR A (dB) | PSNR B (dB) | SSIM A | SSIM B | painting A (s) | painting B (s) | A/B time | A/B fastest |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    totals = {"psnr": {"A": [], "B": []}, "time": {"A": [], "B": []}, "fastest": {"A": [], "B": []}}
    with tempfile.TemporaryDirectory() as tmp:
        for photo in args.photos:
            seconds, result = {"A": [], "B": []}, {}
            for _ in range(args.repeats):
                for side, src in sides.items():
                    os.environ["PYTHONPATH"] = str(src)  # the subprocess imports this checkout's nsp
                    run = paint_once(photo, args.brush, args.strokes, Path(tmp) / side)
                    seconds[side].append(run["painting"])
                    result[side] = run["metrics"]
            median = {side: statistics.median(values) for side, values in seconds.items()}
            fastest = {side: min(values) for side, values in seconds.items()}
            for side in sides:
                totals["psnr"][side].append(result[side]["psnr"])
                totals["time"][side].append(median[side])
                totals["fastest"][side].append(fastest[side])
            rows.append(f"| {photo} | {result['A']['psnr']:.2f} | {result['B']['psnr']:.2f} | {result['A']['ssim']:.3f} "
                        f"| {result['B']['ssim']:.3f} | {median['A']:.2f} | {median['B']:.2f} | "
                        f"{median['A'] / median['B']:.3f} | {fastest['A'] / fastest['B']:.3f} |")
            print(rows[-1], flush=True)
    mean = {kind: {side: statistics.mean(v) for side, v in values.items()} for kind, values in totals.items()}
    rows.append(f"| **mean** | **{mean['psnr']['A']:.2f}** | **{mean['psnr']['B']:.2f}** | | | "
                f"**{mean['time']['A']:.2f}** | **{mean['time']['B']:.2f}** | "
                f"**{mean['time']['A'] / mean['time']['B']:.3f}** | **{mean['fastest']['A'] / mean['fastest']['B']:.3f}** |")
    print(rows[-1])
    if args.section:
        command = (f"python benchmarks/painter_ab.py --base B --brush {args.brush} --strokes {args.strokes} "
                   f"--repeats {args.repeats} --photos {' '.join(args.photos)}")
        write_section(args.section, "\n".join([
            f"A: this commit; B: the checkout named below. Each photo painted by each, alternately, {args.repeats} "
            "times, one painting at a time (`painting` is metrics.json's `painting_seconds`, the median; *A/B fastest* the "
            "ratio of the fastest of each, the least disturbed on a shared machine; PSNR and "
            "SSIM of final.png at a 256-px long side, as in the painter benchmark).", "",
            f"Command: `{command}`  ", f"Machine: {machine()}, no GPU, nothing else running; {args.date}", "", *rows]))


if __name__ == "__main__":
    torch.set_num_threads(1)
    main()
