"""A painting in paints, layer by layer: docs/img/layers.png.

    python benchmarks/layers.py [--image astronaut] [--brush markerpen] [--strokes 300] [--paints 6] [--size 256]

Paints ``python -m nsp.paint image=I brush=B strokes=N paints=K`` (defaults otherwise), then draws from its
strokes.json each paint's strokes alone on white (top row: what the machine lays with that paint) and the
painting once each paint is down (bottom row: the last is final.png), ``--size`` px on the long side.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import torch
from PIL import Image

from nsp.engine import paint_canvas
from nsp.io.plot import layers
from nsp.io.strokes import load_strokes

PICTURE = Path(__file__).resolve().parent.parent / "docs" / "img" / "layers.png"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--image", default="astronaut")
    parser.add_argument("--brush", default="markerpen")
    parser.add_argument("--strokes", type=int, default=300)
    parser.add_argument("--paints", type=int, default=6)
    parser.add_argument("--size", type=int, default=256)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "nsp.paint", f"image={args.image}", f"brush={args.brush}",
                        f"strokes={args.strokes}", f"paints={args.paints}", "progress=false", f"hydra.run.dir={tmp}"],
                       check=True)
        painting = load_strokes(Path(tmp) / "strokes.json")
    brush, strokes = painting.brush, painting.strokes
    height, width = painting.size(args.size)
    layer = torch.from_numpy(layers(brush, strokes.double().numpy(), painting.paints))  # as plot.svg takes them
    alone, after = [], []
    with torch.no_grad():
        for index in range(len(painting.paints)):
            alone.append(paint_canvas(brush, strokes[layer == index], height, width))
            after.append(paint_canvas(brush, strokes[layer <= index], height, width))  # the layers are in order
    rows = [torch.cat(images, 2) for images in (alone, after)]
    picture = (torch.cat(rows, 1).permute(1, 2, 0).clamp(0, 1) * 255).round().byte().numpy()
    Image.fromarray(np.ascontiguousarray(picture)).save(PICTURE)
    print(f"wrote {PICTURE}: {len(painting.paints)} paints ({' '.join(painting.paints)}), {len(strokes)} strokes")


if __name__ == "__main__":
    main()
