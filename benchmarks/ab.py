"""Painter A/B: this checkout against another, the same paintings made in turn.

    python benchmarks/ab.py --base CHECKOUT [--brushes watercolor markerpen] [--photos ...] [--strokes 500] [--repeats 2]

Each painting is ``python -m nsp.paint image=P brush=B strokes=N`` (defaults otherwise), one process at a
time: the base checkout's, then this one's, ``--repeats`` times over, so a slower or busier minute of the
machine falls on both; the fastest of each side counts. Compile both checkouts' kernels first
(``python -m nsp.engine`` with each on the path): each has its own. Prints each painting and, per brush,
the mean change of PSNR (the command's own) and the ratio of painting times (metrics.json's
``painting_seconds``) and of whole commands; writes the "Painter A/B" section of docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402

PHOTOS = ("astronaut", "chelsea", "coffee", "rocket", "flower", "china")  # nsp's built-in photos


def paint(src: Path, photo: str, brush: str, strokes: int, out: Path, *overrides: str) -> dict:
    """One ``python -m nsp.paint`` (and ``overrides``) with ``src`` on the path: its wall seconds and metrics.json."""
    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "nsp.paint", f"image={photo}", f"brush={brush}", f"strokes={strokes}",
                    "progress=false", f"hydra.run.dir={out}", *overrides], env=os.environ | {"PYTHONPATH": str(src)},
                   check=True, capture_output=True)
    return {"wall": time.perf_counter() - start} | json.loads((out / "metrics.json").read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True, help="the other checkout (its src/ is put on the path)")
    parser.add_argument("--brushes", nargs="+", default=["watercolor", "markerpen"])
    parser.add_argument("--photos", nargs="+", default=list(PHOTOS))
    parser.add_argument("--strokes", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--date", default=time.strftime("%Y-%m-%d"))
    args = parser.parse_args()
    sides = {"base": args.base.resolve() / "src", "this": Path(__file__).resolve().parent.parent / "src"}
    rows = ["| brush | photo | PSNR base → this (dB) | painting base → this (s) | command base → this (s) |",
            "|---|---|---:|---:|---:|"]
    summary = []
    with tempfile.TemporaryDirectory() as tmp:
        for brush in args.brushes:
            best = {}
            for photo in args.photos:
                runs = {side: [] for side in sides}
                for _ in range(args.repeats):
                    for side, src in sides.items():
                        runs[side].append(paint(src, photo, brush, args.strokes, Path(tmp) / side))
                best[photo] = {side: {"psnr": got[0]["psnr"], "painting": min(r["painting_seconds"] for r in got),
                                      "wall": min(r["wall"] for r in got)} for side, got in runs.items()}
                b, t = best[photo]["base"], best[photo]["this"]
                rows.append(f"| {brush} | {photo} | {b['psnr']:.2f} → {t['psnr']:.2f} | {b['painting']:.2f} → "
                            f"{t['painting']:.2f} | {b['wall']:.2f} → {t['wall']:.2f} |")
                print(rows[-1], flush=True)
            change = statistics.mean(best[p]["this"]["psnr"] - best[p]["base"]["psnr"] for p in args.photos)
            ratio = {key: sum(best[p]["this"][key] for p in args.photos) / sum(best[p]["base"][key] for p in args.photos)
                     for key in ("painting", "wall")}
            summary.append(f"- {brush}: PSNR {change:+.2f} dB on average; painting time ×{ratio['painting']:.3f}, "
                           f"whole command ×{ratio['wall']:.3f} (sums over the photos)")
            print(summary[-1], flush=True)
    command = (f"python benchmarks/ab.py --base B --brushes {' '.join(args.brushes)} --photos {' '.join(args.photos)} "
               f"--strokes {args.strokes} --repeats {args.repeats}")
    write_section("Painter A/B", "\n".join([
        "The same paintings by two checkouts, made in turn, one process at a time (the fastest of each side's "
        "repeats); PSNR is the command's own (metrics.json), painting the painter's time, command the whole "
        "`python -m nsp.paint`, files included.", "",
        f"Command: `{command}` (B: the checkout before the change)  ", f"Machine: {machine()}, no GPU; {args.date}",
        "", *rows, "", *summary]))


if __name__ == "__main__":
    main()
