"""Where a new stroke starts (paper §3, "active set"): at the block's largest error, in the target's
colour there, so the optimizer refines a stroke that already helps instead of searching for one;
and along the edges there, as a painter's brush follows forms (+0.4–0.9 dB over random angles)."""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes import Brush


def _window(image: Tensor) -> Tensor:
    """Average over a window about an eighth of the block wide (odd, ≥ 3): (B, C, h, w) -> same."""
    k = max(3, min(image.shape[-2:]) // 8 | 1)
    return F.avg_pool2d(image, k, stride=1, padding=k // 2, count_include_pad=False)


def largest_error(canvas: Tensor, target: Tensor, weights: Tensor) -> tuple[Tensor, Tensor]:
    """Pixel (row, col) of the largest locally averaged |canvas − target| per block.

    canvas, target: (B, 3, h, w); weights: (B, 1, h, w), 0 where a pixel is padding.
    Returns two (B,) long tensors. Averaging makes the pick a region that is wrong rather than
    one stray pixel.
    """
    error = _window((canvas - target).abs().sum(1, keepdim=True) * weights)
    index = error.flatten(1).argmax(1)
    width = canvas.shape[-1]
    return index // width, index % width


def edge_direction(target: Tensor, row: Tensor, col: Tensor) -> tuple[Tensor, Tensor]:
    """Direction along the edges at (row, col) of each block: (B,) angle in radians (x right, y
    down), perpendicular to the dominant luminance gradient of the structure tensor averaged
    around it; and (B,) bool, whether there is any gradient to follow."""
    gray = target.mean(1, keepdim=True)
    gx = F.pad(gray[..., :, 2:] - gray[..., :, :-2], (1, 1, 0, 0), mode="replicate")
    gy = F.pad(gray[..., 2:, :] - gray[..., :-2, :], (0, 0, 1, 1), mode="replicate")
    structure = _window(torch.cat([gx * gx, gy * gy, gx * gy], 1))
    jxx, jyy, jxy = structure[torch.arange(len(row)), :, row, col].unbind(1)
    return 0.5 * torch.atan2(2 * jxy, jxx - jyy) + math.pi / 2, jxx + jyy > 1e-8


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
        generator: draws sizes and the directions on flat targets.

    Returns:
        (B, d) strokes in block coordinates, in [0, 1], pointing along the edges at the error (a
        random direction where the target is flat): positions spread along it (a single point for
        rectangles, the control points of a straight Bézier), the angle of a rectangle along it,
        every colour the target's, transparency 1. The first size is uniform in
        ``size``; further ones (a rectangle's thickness, a Bézier's end radius) are 30–100 % of it,
        so strokes start elongated or tapered, like brush strokes.
    """
    batch, _, h, w = canvas.shape
    row, col = largest_error(canvas, target, weights)
    color = target[torch.arange(batch), :, row, col]  # (B, 3)
    lo, hi = size

    def draw() -> Tensor:  # (B,) uniform in [0, 1)
        return torch.rand(batch, generator=generator)

    x = torch.full((batch, brush.d), 0.5)  # kinds set nowhere below (a relative control point): the middle
    xs = [i for i, k in enumerate(brush.kinds) if k == "x"]
    ys = [i for i, k in enumerate(brush.kinds) if k == "y"]
    spread = torch.linspace(-1, 1, len(xs)) if len(xs) > 1 else torch.zeros(1)  # (n,)
    along, edged = edge_direction(target, row, col)
    direction = torch.where(edged, along, 2 * math.pi * draw())
    half = (lo + (hi - lo) * draw()) / 2
    x[:, xs] = col[:, None] / max(w - 1, 1) + spread * (half * torch.cos(direction))[:, None]
    x[:, ys] = row[:, None] / max(h - 1, 1) + spread * (half * torch.sin(direction))[:, None]
    colors, first = 0, lo + (hi - lo) * draw()
    for i, kind in enumerate(brush.kinds):
        if kind == "size":
            x[:, i] = first if i == brush.kinds.index("size") else first * (0.3 + 0.7 * draw())
        elif kind == "angle":
            x[:, i] = (direction / math.pi) % 1  # θ·π is the rotation; a rectangle's axis has no head
        elif kind == "color":
            x[:, i] = color[:, colors % 3]
            colors += 1
        elif kind == "alpha":
            x[:, i] = 1.0
    return x.clamp(0, 1)
