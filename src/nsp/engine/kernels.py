"""The engine's per-pair work: for each (stroke, tile) pair, whether the stroke can reach the tile,
and the colour and alpha it paints there. Elementwise over pairs and pixels, this is most of a
render's time, and what :mod:`nsp.engine.fused` compiles."""
from __future__ import annotations

import functools
import math

import torch
from torch import Tensor

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.geometry import Search, antialiased, nearest_search, soft


def tile_offsets(tile: int, like: Tensor) -> tuple[Tensor, Tensor]:
    """(tile²,) x and y offsets of a tile's pixels from its corner: pixel n lies on row n // tile,
    column n % tile."""
    offsets = torch.arange(tile, device=like.device, dtype=like.dtype)
    return offsets.repeat(tile), offsets.repeat_interleave(tile)


def near_tiles(brush: Brush, x: Tensor, t: Tensor, *, height: int, width: int, tile: int, margin: float) -> Tensor:
    """(P,) whether stroke x[p] (P, d) can reach tile t[p] (P,) of a ``height``×``width`` canvas cut
    into ``tile``-pixel tiles, row by row, within ``margin`` px: the brush's 1-Lipschitz distance
    bound at the tile's centre, which its pixel centres lie within (tile − 1)/√2 of."""
    cols = math.ceil(width / tile)
    cx = (t % cols).to(x.dtype) * tile + (tile - 1) / 2
    cy = torch.div(t, cols, rounding_mode="floor").to(x.dtype) * tile + (tile - 1) / 2
    return brush.bound(x, Pixels(cx[:, None], cy[:, None], height, width))[:, 0] <= (tile - 1) / math.sqrt(2) + margin


def shade_tiles(
    brush: Brush, x: Tensor, t: Tensor, key: Tensor, dx: Tensor, dy: Tensor, *, height: int, width: int, tile: int,
    softness: float | None, search: Search | None = None,
) -> tuple[Tensor, Tensor]:
    """Foreground (P, 3, n) and alpha (P, n) of strokes x (P, d) keyed ``key`` (P,) int64 (see
    :class:`~nsp.brushes.base.Pixels`) on tiles t (P,) (as in :func:`near_tiles`), whose pixel k
    lies (dx[k], dy[k]) from the tile's corner (n = tile², :func:`tile_offsets`); ``softness``:
    None for :func:`antialiased` edges, else :func:`soft`; ``search`` as :class:`~nsp.brushes.base.Pixels`'."""
    cols = math.ceil(width / tile)
    px = ((t % cols) * tile).to(x.dtype)[:, None] + dx
    py = (torch.div(t, cols, rounding_mode="floor") * tile).to(x.dtype)[:, None] + dy
    coverage = antialiased if softness is None else functools.partial(soft, softness=softness)
    return brush.paint(x, Pixels(px, py, height, width, key[:, None], search), coverage)


def nearest_points(brush: Brush, p0: Tensor, a: Tensor, b: Tensor, px: Tensor, py: Tensor, taper: Tensor, *,
                   samples: int, pixels: int) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """:func:`~nsp.brushes.geometry.nearest_search` for a Bézier brush's curves B(t) = P0 + 2t·a + t²·b
    (p0, a, b (P, 2) pixels; ``taper`` (P,), zeros for none) at ``pixels`` pixels each (px, py (P, pixels))."""
    return nearest_search(p0, a, b, px, py, taper, samples)
