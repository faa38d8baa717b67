"""Where a new stroke starts (paper §3, "active set"): at the block's largest error, in the target's
colour there, so the optimizer refines a stroke that already helps instead of searching for one."""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes import Brush


def largest_error(canvas: Tensor, target: Tensor, weights: Tensor) -> tuple[Tensor, Tensor]:
    """Pixel (row, col) of the largest locally averaged |canvas − target| per block.

    canvas, target: (B, 3, h, w); weights: (B, 1, h, w), 0 where a pixel is padding.
    Returns two (B,) long tensors. Averaging over about an eighth of the block makes the pick a
    region that is wrong rather than one stray pixel.
    """
    error = (canvas - target).abs().sum(1, keepdim=True) * weights
    k = max(3, min(canvas.shape[-2:]) // 8 | 1)
    error = F.avg_pool2d(error, k, stride=1, padding=k // 2, count_include_pad=False)
    index = error.flatten(1).argmax(1)
    width = canvas.shape[-1]
    return index // width, index % width


def place_strokes(
    brush: Brush,
    canvas: Tensor,
    target: Tensor,
    weights: Tensor,
    size: tuple[float, float],
    generator: torch.Generator,
) -> Tensor:
    """One new stroke per block, centred on its largest error and coloured like the target there.

    Args:
        brush: the brush.
        canvas, target: (B, 3, h, w) the block as painted so far and as it should look.
        weights: (B, 1, h, w), 0 on padding.
        size: range of the initial sizes, as fractions of the block's width.
        generator: draws sizes, angles and directions.

    Returns:
        (B, d) strokes in block coordinates, in [0, 1]: positions spread along a random direction
        through the error (a single point for rectangles, the control points of a straight Bézier),
        a random angle, every colour the target's, transparency 1. The first size is uniform in
        ``size``; further ones (a rectangle's thickness, a Bézier's end radius) are 30–100 % of it,
        so strokes start elongated or tapered, like brush strokes.
    """
    batch, _, h, w = canvas.shape
    row, col = largest_error(canvas, target, weights)
    color = target[torch.arange(batch), :, row, col]  # (B, 3)
    lo, hi = size
    draw = lambda: torch.rand(batch, generator=generator)  # noqa: E731
    x = torch.empty(batch, brush.d)
    xs = [i for i, k in enumerate(brush.kinds) if k == "x"]
    ys = [i for i, k in enumerate(brush.kinds) if k == "y"]
    spread = torch.linspace(-1, 1, len(xs)) if len(xs) > 1 else torch.zeros(1)  # (n,)
    direction = 2 * math.pi * draw()
    half = (lo + (hi - lo) * draw()) / 2
    x[:, xs] = col[:, None] / max(w - 1, 1) + spread * (half * torch.cos(direction))[:, None]
    x[:, ys] = row[:, None] / max(h - 1, 1) + spread * (half * torch.sin(direction))[:, None]
    colors, first = 0, lo + (hi - lo) * draw()
    for i, kind in enumerate(brush.kinds):
        if kind == "size":
            x[:, i] = first if i == brush.kinds.index("size") else first * (0.3 + 0.7 * draw())
        elif kind == "angle":
            x[:, i] = draw()
        elif kind == "color":
            x[:, i] = color[:, colors % 3]
            colors += 1
        elif kind == "alpha":
            x[:, i] = 1.0
    return x.clamp(0, 1)
