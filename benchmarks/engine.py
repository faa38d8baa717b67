"""Vector engine throughput: strokes/s at 128 px per brush, batch 1 and 256, CPU (and CUDA).

    python benchmarks/engine.py [--seconds 3]

Prints a markdown table and writes it to the "Vector engine" section of docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
import time

import torch

from nsp.brushes import BRUSHES
from nsp.engine import render
from nsp.engine.raster import rasterize

from doc import machine, write_section  # benchmarks/doc.py, beside this script

# The reference implementation's OpenCV engine on this machine (one core, moderate sizes), strokes/s.
REFERENCE = {"watercolor": 890, "markerpen": 420, "tape": 8000}


def strokes(name: str, n: int, moderate: bool, device) -> torch.Tensor:
    brush = BRUSHES[name]
    x = brush.sample(n, torch.Generator().manual_seed(0)).to(device)
    if moderate:  # sizes in the lower quarter of their range
        x[:, [i for i, k in enumerate(brush.kinds) if k == "size"]] *= 0.25
    return x


def rate(name: str, batch: int, moderate: bool, device, seconds: float, sparse: bool = False) -> float:
    brush, x = BRUSHES[name], strokes(name, batch, moderate, device)
    draw = (lambda: rasterize(brush, x, 128, 128)) if sparse else (lambda: render(brush, x, 128))
    draw()
    done, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        draw()
        done += batch
    if device.type == "cuda":
        torch.cuda.synchronize()
    return done / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="time per measurement")
    args = parser.parse_args()
    devices = [torch.device("cpu")] + ([torch.device("cuda")] if torch.cuda.is_available() else [])
    rows = ["| device | brush | sizes | batch 1 | batch 256 | batch 256, tiles only | reference (OpenCV, 1 core) "
            "| batch 256 / reference |", "|---|---|---|---:|---:|---:|---:|---:|"]
    for device in devices:
        for name in BRUSHES:
            for moderate in (True, False):
                one = rate(name, 1, moderate, device, args.seconds)
                many = rate(name, 256, moderate, device, args.seconds)
                tiles = rate(name, 256, moderate, device, args.seconds, sparse=True)
                ref = REFERENCE.get(name)
                ratio = f"{many / ref:.1f}×" if ref and moderate else "—"
                rows.append(
                    f"| {device.type} | {name} | {'moderate' if moderate else 'uniform'} | {one:,.0f} | {many:,.0f} | {tiles:,.0f} "
                    f"| {f'{ref:,}' if ref and moderate else '—'} | {ratio} |"
                )
                print(rows[-1], flush=True)
    body = (
        "Strokes rendered per second at 128×128 (foreground + alpha, antialiased), random strokes:\n"
        "*uniform* over the whole parameter space (what renderer training draws), *moderate* with sizes\n"
        "in the lower quarter of their range (comparable with the reference's \"moderate stroke sizes\").\n"
        "*batch 256* returns dense (B, 4, 128, 128) images; *tiles only* stops at the sparse (stroke, tile)\n"
        "pixels that `paint_canvas` composites (no dense per-stroke image is written).\n\n"
        f"Command: `python benchmarks/engine.py --seconds {args.seconds:g}`  \nMachine: {machine()}\n\n"
        + "\n".join(rows)
    )
    write_section("Vector engine", body)


if __name__ == "__main__":
    main()
