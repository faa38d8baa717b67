"""Reference stroke files: the reference implementation's own random strokes, drawn by its OpenCV
engine and re-rendered by ``nsp.render`` from the ``.npz`` file it would save, compared pixel by
pixel.

    python benchmarks/reference.py --reference PATH [--strokes 200] [--size 256]

PATH is a checkout of github.com/jiupinjia/stylized-neural-painting (non-commercial licence: it is
run here, in its own process, never copied); its engine needs OpenCV (``pip install
opencv-python-headless``). For each of its brushes whose files nsp imports with its own geometry
(watercolor, markerpen, rectangle → tape), it paints ``--strokes`` strokes of its own random
sampler (those its ``check_stroke`` keeps) on a white canvas; nsp imports the arrays
(``load_strokes``) and paints them on white at the same size. PSNR plain, and with one pixel of
tolerance (each reference pixel against the nearest of nsp's 3 × 3 around it). Writes the
"Reference stroke files" section of docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402

BRUSHES = {"watercolor": "watercolor", "markerpen": "markerpen", "rectangle": "tape"}  # reference name -> nsp's

# Prints the seconds its engine spent drawing (draw_stroke alone: not the sampling, not the start-up).
DRAW = """
import random, sys, time
import numpy as np
import renderer
name, count, size, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
random.seed(0)
engine = renderer.Renderer(renderer=name, CANVAS_WIDTH=size, canvas_color="white")
kept, seconds = [], 0.0
while len(kept) < count:
    engine.random_stroke_params()
    engine.stroke_params = engine.stroke_params.astype(np.float64)  # Python floats to OpenCV under numpy 2
    if engine.check_stroke():
        start = time.perf_counter()
        engine.draw_stroke()
        seconds += time.perf_counter() - start
        kept.append(engine.stroke_params.copy())
p = np.array(kept)[None]
np.savez(out, x_ctt=p[..., :engine.d_shape], x_color=p[..., engine.d_shape:engine.d_shape + engine.d_color],
         x_alpha=p[..., -1:], canvas=engine.canvas)
print(seconds)
"""


def draw(reference: Path, name: str, count: int, size: int, path: Path) -> float:
    """The reference's engine paints ``count`` of its random ``name`` strokes on a white ``size``-px
    canvas in its own process, saving them as ``path`` (.npz); returns the seconds it spent drawing."""
    run = subprocess.run([sys.executable, "-c", DRAW, name, str(count), str(size), str(path)], cwd=reference, check=True,
                         capture_output=True, text=True,
                         env=os.environ | {"PYTHONPATH": os.pathsep.join([str(reference), os.environ.get("PYTHONPATH", "")])})
    return float(run.stdout.split()[-1])


def compare(reference: Path, name: str, count: int, size: int, tmp: Path) -> tuple[float, float]:
    from nsp.engine import paint_canvas
    from nsp.io.strokes import load_strokes

    path = tmp / f"{name}.npz"
    draw(reference, name, count, size, path)
    theirs = torch.from_numpy(np.load(path)["canvas"]).permute(2, 0, 1).double()
    painting = load_strokes(path, brush=BRUSHES[name], size=size)
    with torch.no_grad():
        ours = paint_canvas(painting.brush, painting.strokes, size, size, "white").double()
    plain = F.mse_loss(ours, theirs)
    near = F.unfold(F.pad(ours[None], (1, 1, 1, 1), mode="replicate"), 3).view(3, 9, size, size)
    tolerant = ((near - theirs[:, None]) ** 2).min(1).values.mean()
    return float(-10 * torch.log10(plain)), float(-10 * torch.log10(tolerant))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", type=Path, required=True, help="a checkout of the reference implementation")
    parser.add_argument("--strokes", type=int, default=200)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--date", default=time.strftime("%Y-%m-%d"))
    args = parser.parse_args()
    rows = ["| reference brush | nsp brush | PSNR (dB) | PSNR, one pixel of tolerance (dB) |", "|---|---|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        for name, ours in BRUSHES.items():
            plain, tolerant = compare(args.reference.resolve(), name, args.strokes, args.size, Path(tmp))
            rows.append(f"| {name} | {ours} | {plain:.1f} | {tolerant:.1f} |")
            print(rows[-1], flush=True)
    write_section("Reference stroke files", "\n".join([
        f"The reference implementation's random strokes ({args.strokes} a brush, its own sampler, seed 0), drawn by its "
        f"OpenCV engine on a white {args.size}-px canvas, and its `.npz` arrays re-rendered by nsp on white at the same "
        "size. Its oil brush is left out: its texture images are its own, and nsp's oil paint is another brush's "
        "look on the same geometry.", "",
        f"Command: `python benchmarks/reference.py --reference PATH --strokes {args.strokes} --size {args.size}` "
        "(PATH: a checkout of github.com/jiupinjia/stylized-neural-painting, run with OpenCV, never copied)  ",
        f"Machine: {machine()}, no GPU; {args.date}", "", *rows]))


if __name__ == "__main__":
    main()
