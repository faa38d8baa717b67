"""What painting in K paints costs: the same paintings with and without ``paints=K``, and how a browser's
renderer draws their plot.svg.

    python benchmarks/paints.py [--brushes markerpen watercolor tape oilpaint] [--photos ...] [--strokes 300] [--paints 6]

Each pair is ``python -m nsp.paint image=P brush=B strokes=N`` and the same with ``paints=K`` (defaults
otherwise), one process at a time. Prints each pair: the two PSNRs (the command's own, final.png against
the photo), the loss, the seconds laying the paints took (metrics.json's ``laying_seconds``) and plot.svg
as resvg draws it against final.png at 256 px; per brush, the mean and the worst loss over the photos.
Writes the "Paints" section of docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import resvg_py
import torch
from PIL import Image

sys.path.insert(0, str(Path(__file__).parent))
from ab import PHOTOS, paint  # noqa: E402
from doc import machine, write_section  # noqa: E402

from nsp.images import load_image, psnr, resize  # noqa: E402

SRC = Path(__file__).resolve().parent.parent / "src"


def drawn(run: Path, size: int = 256) -> float:
    """PSNR (dB) of the run's plot.svg as resvg draws it, on white, against its final.png, at ``size`` px."""
    rgba = np.asarray(Image.open(io.BytesIO(bytes(resvg_py.svg_to_bytes(svg_path=str(run / "plot.svg"))))).convert("RGBA")) / 255
    on_paper = torch.tensor(rgba[..., :3] * rgba[..., 3:] + 1 - rgba[..., 3:]).permute(2, 0, 1).float()
    return float(psnr(resize(on_paper, size), resize(load_image(str(run / "final.png")), size)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--brushes", nargs="+", default=["markerpen", "watercolor", "tape", "oilpaint"])
    parser.add_argument("--photos", nargs="+", default=list(PHOTOS))
    parser.add_argument("--strokes", type=int, default=300)
    parser.add_argument("--paints", type=int, default=6)
    parser.add_argument("--date", default=time.strftime("%Y-%m-%d"))
    args = parser.parse_args()
    rows = ["| brush | photo | PSNR free (dB) | in paints (dB) | loss (dB) | laying (s) | plot.svg vs final.png (dB) |",
            "|---|---|---:|---:|---:|---:|---:|"]
    summary = ["| brush | mean loss (dB) | worst loss (dB) | mean laying (s) |", "|---|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        for brush in args.brushes:
            losses, laying = [], []
            for photo in args.photos:
                free = paint(SRC, photo, brush, args.strokes, Path(tmp) / "free")
                run = Path(tmp) / "paints"
                laid = paint(SRC, photo, brush, args.strokes, run, f"paints={args.paints}")
                losses.append(free["psnr"] - laid["psnr"])
                laying.append(laid["laying_seconds"])
                rows.append(f"| {brush} | {photo} | {free['psnr']:.2f} | {laid['psnr']:.2f} | {losses[-1]:.2f} | "
                            f"{laying[-1]:.1f} | {drawn(run):.1f} |")
                print(rows[-1], flush=True)
            summary.append(f"| {brush} | {statistics.mean(losses):.2f} | {max(losses):.2f} | {statistics.mean(laying):.1f} |")
            print(summary[-1], flush=True)
    command = (f"python benchmarks/paints.py --brushes {' '.join(args.brushes)} --photos {' '.join(args.photos)} "
               f"--strokes {args.strokes} --paints {args.paints}")
    write_section("Paints", f"""`{command}`, {args.date}, on a {machine()}. Each photo painted with
`python -m nsp.paint image=P brush=B strokes={args.strokes}` and the same with `paints={args.paints}`; the loss is
the first's PSNR minus the second's (final.png against the photo, the command's own); plot.svg drawn by resvg
against final.png at 256 px.

{chr(10).join(summary)}

{chr(10).join(rows)}
""")


if __name__ == "__main__":
    main()
