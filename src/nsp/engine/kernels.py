"""The engine's per-pair work, elementwise, most of a render's time and what :mod:`nsp.engine.fused`
compiles: for each (stroke, tile) pair, whether the stroke can reach the tile, and what it paints there."""
from __future__ import annotations

import functools
import math

import torch
from torch import Tensor

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.geometry import antialiased, soft


def tile_offsets(tile: int, like: Tensor) -> tuple[Tensor, Tensor]:
    """(tile²,) x and y offsets of a tile's pixels from its corner: pixel n on row n // tile, column n % tile."""
    offsets = torch.arange(tile, device=like.device, dtype=like.dtype)
    return offsets.repeat(tile), offsets.repeat_interleave(tile)


def near_tiles(brush: Brush, x: Tensor, t: Tensor, *, height: int, width: int, tile: int, margin: float) -> Tensor:
    """(P,) whether stroke x[p] (P, d) can reach tile t[p] (P,), row by row, of a ``height``×``width`` canvas
    within ``margin`` px: its 1-Lipschitz distance bound at the tile's centre, its pixels within (tile − 1)/√2."""
    cols = math.ceil(width / tile)
    cx = (t % cols).to(x.dtype) * tile + (tile - 1) / 2
    cy = torch.div(t, cols, rounding_mode="floor").to(x.dtype) * tile + (tile - 1) / 2
    return brush.bound(x, Pixels(cx[:, None], cy[:, None], height, width))[:, 0] <= (tile - 1) / math.sqrt(2) + margin


def shade_tiles(brush: Brush, x: Tensor, t: Tensor, key: Tensor, dx: Tensor, dy: Tensor, *, height: int, width: int,
                tile: int, softness: float | None) -> tuple[Tensor, Tensor]:
    """Foreground (P, 3, n) and alpha (P, n) of strokes x (P, d) keyed ``key`` (P,) int64 (see :class:`Pixels`)
    on tiles t (P,) (:func:`near_tiles`), whose pixel k lies (dx[k], dy[k]) from the tile's corner (n = tile²,
    :func:`tile_offsets`); ``softness``: None for :func:`antialiased` edges, else :func:`soft`."""
    cols = -(-width // tile)  # ⌈width / tile⌉, of an int or a tensor
    px = ((t % cols) * tile).to(x.dtype)[:, None] + dx
    py = (torch.div(t, cols, rounding_mode="floor") * tile).to(x.dtype)[:, None] + dy
    coverage = antialiased if softness is None else functools.partial(soft, softness=softness)
    return brush.paint(x, Pixels(px, py, height, width, key[:, None]), coverage)


def shade_any_size(brush: Brush, x: Tensor, t: Tensor, key: Tensor, dx: Tensor, dy: Tensor, canvas: Tensor, *,
                   tile: int, softness: float | None) -> tuple[Tensor, Tensor]:
    """:func:`shade_tiles` on a canvas whose (height, width) is the tensor ``canvas`` (2,): one compiled
    kernel serves every canvas size, for a brush that shades them all alike (:meth:`~nsp.brushes.Brush.sized`)."""
    return shade_tiles(brush, x, t, key, dx, dy, height=canvas[0], width=canvas[1], tile=tile, softness=softness)


def shade_any_size_grad(brush: Brush, x: Tensor, t: Tensor, key: Tensor, grad_fg: Tensor, grad_alpha: Tensor,
                        dx: Tensor, dy: Tensor, canvas: Tensor, *, tile: int, softness: float) -> Tensor:
    """The gradient (P, d) of :func:`shade_any_size`' outputs at x (P, d) along ``grad_fg`` (P, 3, n) and
    ``grad_alpha`` (P, n): the pairs' shading run again, then back, in one kernel once compiled."""
    with torch.enable_grad():
        x = x.detach().requires_grad_()
        fg, alpha = shade_any_size(brush, x, t, key, dx, dy, canvas, tile=tile, softness=softness)
        return torch.autograd.grad((fg, alpha), x, (grad_fg, grad_alpha))[0]
