"""Paintings as files people open: PNG (the engine), SVG (vector elements), GIF (strokes in order)."""
from __future__ import annotations

import json
import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import torch
from PIL import Image
from torch import Tensor

from nsp.brushes import Brush
from nsp.brushes.svg import hex_color
from nsp.engine.canvas import paint_canvas, parse_color
from nsp.errors import BadInput

EXTENSIONS = (".png", ".svg", ".gif")
GIF_FRAMES = 50  # frames of an animation after its empty canvas


def to_uint8(image: Tensor) -> np.ndarray:
    """(3, H, W) in [0, 1] -> (H, W, 3) uint8."""
    return (image.detach().clamp(0, 1).permute(1, 2, 0).cpu().numpy() * 255 + 0.5).astype(np.uint8)


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it becomes ``path`` only once the write has
    finished, so an interrupted write leaves the old file or none, never a truncated one."""
    path = Path(path)
    temporary = path.with_name(f".{path.stem}.{secrets.token_hex(4)}.tmp{path.suffix}")  # suffix: PIL's format
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_json(path: str | Path, data: dict, indent: int = 2) -> None:
    """Save ``data`` as JSON, atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(json.dumps(data, indent=indent) + "\n")


def write_png(path: str | Path, image: Tensor) -> None:
    """Save a (3, H, W) image in [0, 1]."""
    with atomic_path(path) as temporary:
        Image.fromarray(to_uint8(image)).save(temporary)


def write_gif(
    path: str | Path, brush: Brush, strokes: Tensor, height: int, width: int, background: str = "white",
    frames: int = GIF_FRAMES, seconds: float = 4.0,
) -> None:
    """An animation of the strokes appearing in order, ``frames`` frames, the last held a second;
    no strokes give one frame of the plain canvas."""
    color = torch.tensor(parse_color(background), dtype=strokes.dtype)[:, None, None]
    canvas = color.expand(3, height, width)
    ends = np.unique(np.linspace(0, len(strokes), min(frames, len(strokes)) + 1).round().astype(int))
    # Each frame kept as its palette image (1 byte a pixel) only. Fast octree palettes: Pillow's
    # default quantizer takes seconds per frame.
    palettes = [Image.fromarray(to_uint8(canvas)).quantize(256, Image.Quantize.FASTOCTREE)]
    with torch.no_grad():
        for start, end in zip(ends[:-1], ends[1:]):
            canvas = paint_canvas(brush, strokes[start:end], height, width, canvas=canvas)
            palettes.append(Image.fromarray(to_uint8(canvas)).quantize(256, Image.Quantize.FASTOCTREE))
    durations = [round(1000 * seconds / len(palettes))] * (len(palettes) - 1) + [1000]
    with atomic_path(path) as temporary:
        palettes[0].save(temporary, format="GIF", save_all=True, append_images=palettes[1:], duration=durations, loop=0)


def write_svg(
    path: str | Path, brush: Brush, strokes: Tensor, height: int, width: int, background: str = "white"
) -> None:
    """Each stroke as the brush's SVG elements, in painting order, on a ``height``×``width`` canvas
    (an oil brush's texture, nsp's or the user's, embedded)."""
    defs, body = brush.svg_defs(), []
    for i, p in enumerate(strokes.detach().cpu().double().numpy()):
        d, e = brush.svg(i, p, height, width)
        defs.append(d)
        body.append(e)
    svg = "\n".join(
        [
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="-0.5 -0.5 {width} {height}">',
            "<defs>" + "".join(defs) + "</defs>",
            f'<rect x="-0.5" y="-0.5" width="{width}" height="{height}" fill="{hex_color(parse_color(background))}"/>',
            *body,
            "</svg>",
        ]
    )
    with atomic_path(path) as temporary:
        temporary.write_text(svg)


def write_painting(path: str | Path, brush: Brush, strokes: Tensor, height: int, width: int, background: str) -> None:
    """Write ``path`` as PNG, SVG or GIF by its extension."""
    suffix = Path(path).suffix.lower()
    if suffix == ".png":
        with torch.no_grad():
            write_png(path, paint_canvas(brush, strokes, height, width, background))
    elif suffix == ".svg":
        write_svg(path, brush, strokes, height, width, background)
    elif suffix == ".gif":
        write_gif(path, brush, strokes, height, width, background)
    else:
        raise BadInput(f"out={path}: unknown extension '{suffix}', expected one of {', '.join(EXTENSIONS)}")
