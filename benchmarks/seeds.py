"""PSNR over seeds: this checkout (A) against another (B), ``python -m nsp.paint`` on its defaults
with ``seed=0, 1, …``, A and B in turn; a painting's PSNR moves by a few hundredths of a dB from one
seed (or one rounding of the same arithmetic) to the next, so "PSNR not lower" is read over seeds.

Prints markdown and writes the "PSNR over seeds" section of docs/benchmarks.md.

    git worktree add /tmp/base <commit>
    python benchmarks/seeds.py --base /tmp/base [--brushes oilpaint] [--strokes 500 5000] [--seeds 5 3]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402
from painter import paint_once  # noqa: E402

HERE = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True, help="the other checkout (B): its src/ is imported")
    parser.add_argument("--base-name", default="B", help="what the docs call B (e.g. its date)")
    parser.add_argument("--photo", default="astronaut")
    parser.add_argument("--brushes", nargs="+", default=["oilpaint"])
    parser.add_argument("--strokes", nargs="+", type=int, default=[500, 5000])
    parser.add_argument("--seeds", nargs="+", type=int, default=[5, 3], help="seeds per budget: 0, 1, … (one count a budget)")
    parser.add_argument("--date", default=time.strftime("%Y-%m-%d"))
    args = parser.parse_args()
    sides = {"A": HERE / "src", "B": args.base.resolve() / "src"}
    rows = ["| brush | strokes | seed | PSNR A (dB) | PSNR B (dB) | A − B (dB) | wall A (s) | wall B (s) |",
            "|---|---:|---:|---:|---:|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        for brush, strokes, seeds in ((b, n, k) for b in args.brushes for n, k in zip(args.strokes, args.seeds)):
            differences = []
            for seed in range(seeds):
                runs = {}
                for side, src in sides.items():
                    os.environ["PYTHONPATH"] = str(src)  # the subprocess imports this checkout's nsp
                    runs[side] = paint_once(args.photo, brush, strokes, Path(tmp) / "run", overrides=[f"seed={seed}"])
                a, b = (runs[side]["metrics"]["psnr"] for side in sides)
                differences.append(a - b)
                rows.append(f"| {brush} | {strokes:,} | {seed} | {a:.3f} | {b:.3f} | {a - b:+.3f} | {runs['A']['wall']:.1f} "
                            f"| {runs['B']['wall']:.1f} |")
                print(rows[-1], flush=True)
            spread = statistics.stdev(differences) if len(differences) > 1 else 0.0
            rows.append(f"| {brush} | {strokes:,} | mean | | | {statistics.mean(differences):+.3f} ± {spread:.3f} | | |")
            print(rows[-1], flush=True)
    command = (f"python benchmarks/seeds.py --base B --base-name '{args.base_name}' --photo {args.photo} --brushes {' '.join(args.brushes)} "
               f"--strokes {' '.join(map(str, args.strokes))} --seeds {' '.join(map(str, args.seeds))}")
    write_section("PSNR over seeds", "\n".join([
        f"`python -m nsp.paint image={args.photo} brush=… strokes=N seed=S` on its defaults, A (this commit) and "
        f"B ({args.base_name}) in turn, one fresh process each, with this machine's kernel cache (A's kernels as "
        "`make setup` compiles them); metrics.json's PSNR. The mean and standard deviation "
        "of A − B over the seeds is the comparison; one seed's difference is mostly where rounding led the optimization.",
        "", f"Command: `{command}`  ", f"Machine: {machine()}, nothing else running; {args.date}", "", *rows]))


if __name__ == "__main__":
    main()
