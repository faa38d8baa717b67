"""Painter: wall time and quality of ``python -m nsp.paint`` per brush and stroke count, and the
renderers' time per optimizer step.

Each painting is a fresh ``python -m nsp.paint image=astronaut brush=B strokes=N`` process (defaults
otherwise), so its wall time includes start-up, imports and writing every file; PSNR and SSIM are
from its metrics.json (256-px long side). The step times paint one level of 5×5 blocks with 6
strokes each (the finest levels' shape) and divide by the steps taken. Prints markdown and writes
the "Painter" section of docs/benchmarks.md.

    python benchmarks/painter.py [--brushes oilpaint ...] [--strokes 200 500 1000]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

import torch

from nsp.brushes import BRUSHES, get_brush
from nsp.painter.images import load_image, resize
from nsp.painter.losses import PaintLoss
from nsp.painter.schema import LossConfig
from nsp.painter.painter import Painter
from nsp.painter.renderer import AnalyticRenderer, NeuralRenderer
from nsp.renderers import build

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402

REFERENCE = "The reference implementation's progressive painter (495 oil strokes, 32-px renderer, 512-px output) took 417 s on this machine."


def paint_once(brush: str, strokes: int, out: Path) -> dict:
    """Wall seconds of one ``python -m nsp.paint`` process and its metrics."""
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "nsp.paint", f"brush={brush}", f"strokes={strokes}", "progress=false",
         f"hydra.run.dir={out}"],
        capture_output=True, text=True,
    )
    wall = time.perf_counter() - start
    if result.returncode:
        raise RuntimeError(result.stderr)
    return json.loads((out / "metrics.json").read_text()) | {"wall": wall}


def seconds_per_step(renderer, brush_name: str, steps: int = 4) -> tuple[float, int]:
    """One level of 5×5 blocks × 6 strokes on the 256-px astronaut at ``steps`` steps per stroke:
    seconds per optimizer step, and the block side in pixels the renderer works at."""
    brush = get_brush(brush_name)
    target = resize(load_image("astronaut"), 256)
    painter = Painter(brush, renderer, PaintLoss.from_config(LossConfig()), partial(torch.optim.RMSprop, lr=0.003), grids=[5],
                      steps_per_stroke=steps)
    painter.paint(target, 25)  # warm-up: first-call costs (the optimizer's imports, the texture)
    start = time.perf_counter()
    painter.paint(target, 150)
    return (time.perf_counter() - start) / painter.step, renderer.resolution(painter.levels(150, 256, 256)[0].side)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--brushes", nargs="+", default=list(BRUSHES))
    parser.add_argument("--strokes", nargs="+", type=int, default=[200, 500, 1000])
    args = parser.parse_args()
    torch.set_num_threads(1)  # as nsp.paint's default

    rows = ["| brush | strokes | wall (s) | PSNR (dB) | SSIM |", "|---|---:|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        for brush in args.brushes:
            for strokes in args.strokes:
                m = paint_once(brush, strokes, Path(tmp) / f"{brush}_{strokes}")
                rows.append(f"| {brush} | {strokes} | {m['wall']:.1f} | {m['psnr']:.2f} | {m['ssim']:.3f} |")
                print(rows[-1], flush=True)

    steps = ["| renderer | block pixels | s / step |", "|---|---:|---:|"]
    renderers = [("analytic (soft engine)", AnalyticRenderer(get_brush("oilpaint"), softness=0.5, block_size=64))]
    for size in (32, 64, 128):
        network = build({"_target_": "nsp.renderers.DualPathway", "size": size, "width": 1.0}, "oilpaint")
        renderers.append(("neural (dual, width 1)", NeuralRenderer(network, size)))
    for name, renderer in renderers:
        seconds, pixels = seconds_per_step(renderer, "oilpaint")
        steps.append(f"| {name} | {pixels} | {seconds:.3f} |")
        print(steps[-1], flush=True)

    body = "\n".join([
        "`python -m nsp.paint image=astronaut brush=B strokes=N`, defaults otherwise (analytic renderer, L1 loss, "
        "progressive schedule, 256-px working canvas, 1024-px final.png), one process per painting: wall time "
        "includes start-up and writing every file. PSNR and SSIM against the photo at a 256-px long side. "
        + REFERENCE,
        "",
        "Command: `python benchmarks/painter.py`  ",
        f"Machine: {machine()} (shared with other work while measured)",
        "",
        *rows,
        "",
        "Time per optimizer step of one level of 5×5 blocks with 6 active strokes each (oilpaint, RMSprop, L1); "
        "the neural renderer is the paper's dual-pathway network at full width (untrained weights time the same). "
        "Adding `loss=l1_ot` costs a 48×48 Sinkhorn per block and colour channel on top (see Transport loss).",
        "",
        *steps,
    ])
    write_section("Painter", body)
    print(body)


if __name__ == "__main__":
    main()
