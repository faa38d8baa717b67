"""Where and how a new stroke starts (paper §3.6, "active set"): at the block's largest error, along
the forms there, as large as the colour there reaches and in the target's colours under it, so the
optimizer refines a stroke that already helps instead of searching for one."""
from __future__ import annotations

import math

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.painter.structure import orientation, reach, smooth, structure_tensor


def window(side: int) -> int:
    """Odd window about an eighth of a block ``side`` pixels wide (≥ 3): the neighbourhood that picks
    the error and the direction."""
    return max(3, side // 8 | 1)


def largest_error(canvas: Tensor, target: Tensor, weights: Tensor) -> tuple[Tensor, Tensor]:
    """Pixel (row, col) of the largest locally averaged |canvas − target| per block.

    canvas, target: (B, 3, h, w); weights: (B, 1, h, w), 0 where a pixel is padding.
    Returns two (B,) long tensors. Averaging makes the pick a region that is wrong rather than
    one stray pixel.
    """
    error = smooth((canvas - target).abs().sum(1, keepdim=True) * weights, window(canvas.shape[-1]))
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
    """One new stroke per block, centred on the region of its largest error.

    Args:
        brush: the brush.
        canvas, target: (B, 3, h, w) the block as painted so far and as it should look.
        weights: (B, 1, h, w), 0 on padding.
        size: range of a new stroke's length, as fractions of the block's width.
        generator: draws the directions where the target is flat.

    Returns:
        (B, d) strokes in block coordinates, in [0, 1]. The stroke lies along the target's forms at
        the error (the structure tensor's direction; a random one where the target is flat) and
        spans the stretch, along and across them, over which the target keeps the colour there
        (:func:`~nsp.painter.structure.reach`), its length within ``size``; its colours are the
        target's along that stretch (a two-colour brush's head and tail those of either half);
        transparency 1. Rectangles (brushes with an angle) get centre, length, thickness and angle;
        Bézier brushes a straight centreline and a radius of half the thickness.
    """
    batch, _, h, w = canvas.shape
    row, col = largest_error(canvas, target, weights)
    pick = torch.arange(batch)
    structure = structure_tensor(target, window(w))[pick, :, row, col]  # (B, 3)
    along, coherence = orientation(structure)
    flat = coherence < 0.05
    direction = torch.where(flat, 2 * math.pi * torch.rand(batch, generator=generator, dtype=target.dtype), along)
    seed = smooth(target, 3)[pick, :, row, col]  # (B, 3)
    lo, hi = size[0] * (w - 1) / 2, size[1] * (w - 1) / 2  # half-lengths in block pixels
    colors, dist = reach(target, canvas, row.to(target.dtype), col.to(target.dtype), direction, seed, hi)
    # the stroke spans the walks' stretch: centre halfway between their ends, half-extents clamped
    shift = (dist[:, 0] - dist[:, 1]) / 2
    half = ((dist[:, 0] + dist[:, 1]) / 2).clamp(lo, hi)
    thick = ((dist[:, 2] + dist[:, 3]) / 2).clamp(max(0.5 * lo, 1.0), hi).minimum(half)
    cx = col + shift * torch.cos(direction) + (dist[:, 2] - dist[:, 3]) / 2 * -torch.sin(direction)
    cy = row + shift * torch.sin(direction) + (dist[:, 2] - dist[:, 3]) / 2 * torch.cos(direction)
    head, tail = colors[:, 1].mean(1), colors[:, 0].mean(1)  # (B, 3): the −direction and +direction halves
    middle = colors.mean((1, 2))
    return _stroke(brush, cx / max(w - 1, 1), cy / max(h - 1, 1), direction, 2 * half / (w - 1),
                   2 * thick / (w - 1), (head, tail) if brush.kinds.count("color") == 6 else (middle,))


def _stroke(brush: Brush, cx: Tensor, cy: Tensor, direction: Tensor, length: Tensor, thickness: Tensor,
            colors: tuple[Tensor, ...]) -> Tensor:
    """(B, d) parameters of strokes centred at (cx, cy) (fractions of the block), pointing at
    ``direction`` (radians), ``length`` and ``thickness`` fractions of the block width; ``colors``:
    one (B, 3) per colour of the brush, in parameter order."""
    x = torch.full((len(cx), brush.d), 0.5)
    xs = [i for i, k in enumerate(brush.kinds) if k == "x"]
    ys = [i for i, k in enumerate(brush.kinds) if k == "y"]
    spread = torch.linspace(-0.5, 0.5, len(xs)) if len(xs) > 1 else torch.zeros(1)  # points along the stroke
    x[:, xs] = cx[:, None] + spread * (length * torch.cos(direction))[:, None]
    x[:, ys] = cy[:, None] + spread * (length * torch.sin(direction))[:, None]
    sizes = [i for i, k in enumerate(brush.kinds) if k == "size"]
    rectangle = "angle" in brush.kinds
    # a rectangle's sizes are its length and thickness; a Bézier's are radii of W/4 units (SPEC §2)
    x[:, sizes] = torch.stack([length, thickness], 1)[:, : len(sizes)] if rectangle else (2 * thickness)[:, None]
    x[:, [i for i, k in enumerate(brush.kinds) if k == "angle"]] = ((direction / math.pi) % 1)[:, None]
    x[:, [i for i, k in enumerate(brush.kinds) if k == "color"]] = torch.cat(colors, 1)
    x[:, [i for i, k in enumerate(brush.kinds) if k == "alpha"]] = 1.0
    return x.clamp(0, 1)
