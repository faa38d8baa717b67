"""Whole paintings: an ordered stroke list composited onto a coloured canvas."""
from __future__ import annotations

import re

import torch
from torch import Tensor

from nsp.brushes.base import Brush
from nsp.engine.raster import composite_tiles, rasterize, to_tiles, untile
from nsp.errors import BadInput

_NAMED = {"black": (0.0, 0.0, 0.0), "white": (1.0, 1.0, 1.0)}


def parse_color(value: str | tuple | list) -> tuple[float, float, float]:
    """``black``, ``white``, ``#rrggbb`` or an RGB triple in [0, 1] -> (r, g, b) in [0, 1]."""
    if isinstance(value, (tuple, list)) and len(value) == 3:
        return tuple(float(v) for v in value)
    text = str(value).strip().lower()
    if text in _NAMED:
        return _NAMED[text]
    if re.fullmatch(r"#[0-9a-f]{6}", text):
        return tuple(int(text[i : i + 2], 16) / 255 for i in (1, 3, 5))
    raise BadInput(f"background={value} is not a colour; expected black, white or #rrggbb")


def paint_canvas(
    brush: Brush,
    strokes: Tensor,
    height: int,
    width: int,
    background: str | tuple = "white",
    *,
    softness: float | None = None,
    canvas: Tensor | None = None,
    chunk: int = 256,
    tile: int = 8,
) -> Tensor:
    """Composite ``strokes`` (N, d), in order, onto a canvas: (3, H, W) in [0, 1].

    Only the tiles each stroke touches are rendered and blended, ``chunk`` strokes at a time, so
    a painting of thousands of strokes renders at any size in bounded memory.
    ``canvas`` (3, H, W), if given, replaces the plain ``background``.
    """
    if canvas is None:
        color = torch.tensor(parse_color(background), dtype=strokes.dtype, device=strokes.device)
        canvas = color[:, None, None].expand(3, height, width)
    tiled = to_tiles(canvas, tile)
    for start in range(0, strokes.shape[0], chunk):
        part = rasterize(brush, strokes[start : start + chunk], height, width, softness=softness, tile=tile)
        tiled = composite_tiles(part, tiled)
    return untile(tiled, height, width, tile)
