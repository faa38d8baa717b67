"""What a glaze costs: the same paintings at several ``brush.glaze`` values, and a picture of them.

    python benchmarks/glaze.py [--brushes watercolor markerpen] [--glazes 0 0.05 0.1 0.3] [--strokes 500]

Each painting is ``python -m nsp.paint image=P brush=B brush.glaze=G strokes=N`` (defaults otherwise). Prints
each PSNR (the command's own) and, per brush and glaze, the mean change from the first glaze over the six
built-in photos; writes the "Glazes" section of docs/benchmarks.md and docs/img/glazes.png (chelsea's
paintings side by side, each brush a row, 1:1 crops).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).parent))
from ab import PHOTOS, paint  # noqa: E402
from doc import machine, write_section  # noqa: E402

SRC = Path(__file__).resolve().parent.parent / "src"
PICTURE = Path(__file__).resolve().parent.parent / "docs" / "img" / "glazes.png"
SHOWN, CROP = "chelsea", (260, 120, 660, 420)  # the photo in the picture, and its crop (1:1 of the 1024-px final.png)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--brushes", nargs="+", default=["watercolor", "markerpen"])
    parser.add_argument("--glazes", nargs="+", type=float, default=[0.0, 0.05, 0.1, 0.3])
    parser.add_argument("--photos", nargs="+", default=list(PHOTOS))
    parser.add_argument("--strokes", type=int, default=500)
    parser.add_argument("--date", default=time.strftime("%Y-%m-%d"))
    args = parser.parse_args()
    rows = ["| brush | glaze | " + " | ".join(args.photos) + " | mean change (dB) |",
            "|---|---:|" + "---:|" * (len(args.photos) + 1)]
    crops = []
    with tempfile.TemporaryDirectory() as tmp:
        for brush in args.brushes:
            first, row = None, []
            for glaze in args.glazes:
                psnr = {}
                for photo in args.photos:
                    out = Path(tmp) / f"{brush}-{glaze}-{photo}"
                    psnr[photo] = paint(SRC, photo, brush, args.strokes, out, f"brush.glaze={glaze}")["psnr"]
                    if photo == SHOWN:
                        row.append(np.asarray(Image.open(out / "final.png").convert("RGB").crop(CROP)))
                first = first or psnr
                change = statistics.mean(psnr[p] - first[p] for p in args.photos)
                rows.append(f"| {brush} | {glaze:g} | " + " | ".join(f"{psnr[p]:.2f}" for p in args.photos)
                            + f" | {change:+.2f} |")
                print(rows[-1], flush=True)
            crops.append(np.concatenate(row, 1))
    if SHOWN in args.photos:
        Image.fromarray(np.concatenate(crops, 0)).save(PICTURE)
    command = (f"python benchmarks/glaze.py --brushes {' '.join(args.brushes)} --glazes "
               f"{' '.join(f'{g:g}' for g in args.glazes)} --strokes {args.strokes}")
    write_section("Glazes", "\n".join([
        "PSNR (dB, the command's own) of the same paintings at each `brush.glaze`, and the mean change from "
        f"the first. Picture: docs/img/glazes.png ({SHOWN}, each brush a row, the glazes left to right).", "",
        f"Command: `{command}`  ", f"Machine: {machine()}, no GPU; {args.date}", "", *rows]))


if __name__ == "__main__":
    main()
