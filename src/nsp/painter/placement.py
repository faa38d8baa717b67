"""Where and how a new stroke starts (paper §3.6, "active set"): at the block's largest error, along
the forms there, as large as the colour there reaches and in the target's colours under it, so the
optimizer refines a stroke that already helps instead of searching for one."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.painter.structure import orientation, reach, smooth, structure_tensor


def window(side: int) -> int:
    """Odd window about an eighth of a block ``side`` pixels wide (≥ 3): the neighbourhood that picks
    the error and the direction."""
    return max(3, side // 8 | 1)


@dataclass(frozen=True)
class Forms:
    """What a new stroke reads of target blocks (B, 3, h, w), the same for every stroke of a level:
    the structure tensor J (B, 3, h, w) over a :func:`window` and the 3×3-smoothed colours (B, 3, h, w)."""

    structure: Tensor
    colors: Tensor

    @classmethod
    def of(cls, target: Tensor) -> "Forms":
        return cls(structure_tensor(target, window(target.shape[-1])), smooth(target, 3))

    def __getitem__(self, blocks: Tensor) -> "Forms":
        return Forms(self.structure[blocks], self.colors[blocks])


def largest_errors(canvas: Tensor, target: Tensor, weights: Tensor, count: int = 1) -> tuple[Tensor, Tensor]:
    """Pixels (row, col), two (B, count) long tensors, of the ``count`` largest locally averaged
    |canvas − target| (B, 3, h, w) per block, at least a window apart, largest first; weights
    (B, 1, h, w) are 0 on padding. Averaging makes a pick a region that is wrong rather than one
    stray pixel; keeping only local maxima makes the picks different regions."""
    side = window(canvas.shape[-1])
    error = smooth((canvas - target).abs().sum(1, keepdim=True) * weights, side)
    width = canvas.shape[-1]
    ys, xs = torch.arange(error.shape[-2], device=error.device), torch.arange(width, device=error.device)
    picks = []
    for _ in range(count):  # greedily, each pick clearing its neighbourhood (a plateau gives one pick)
        index = error.flatten(1).argmax(1)
        picks.append(index)
        row, col = index // width, index % width
        near = ((ys[None, :, None] - row[:, None, None]).abs() <= side) & ((xs[None, None] - col[:, None, None]).abs() <= side)
        error = error.masked_fill(near[:, None], -1.0)
    index = torch.stack(picks, 1)
    return index // width, index % width


def place_strokes(brush: Brush, canvas: Tensor, target: Tensor, weights: Tensor, size: tuple[float, float],
                  generator: torch.Generator, peaks: int = 1, scales: Sequence[float] = (1.0,),
                  forms: Forms | None = None) -> Tensor:
    """New strokes for each block of ``canvas`` (B, 3, h, w, as painted so far) toward ``target``
    (as it should look; ``weights`` (B, 1, h, w), 0 on padding), centred on its ``peaks`` regions of
    largest error (:func:`largest_errors`), a stroke per ``scales`` at each, its length that many
    times the reach along the forms (``forms``: ``Forms.of(target)``, a level's, computed once) and
    within ``size`` (fractions of the block's width). ``generator`` draws the directions where the
    target is flat. (B, d) strokes in block coordinates in [0, 1] for one peak and scale, else (B,
    peaks · len(scales), d), peak by peak: along the target's forms at the error, spanning the
    stretch over which the target keeps its colour (:func:`~nsp.painter.structure.reach`), in the
    target's colours along it (a two-colour brush's head and tail those of either half), opaque.
    """
    batch, _, h, w = canvas.shape
    rows, cols = largest_errors(canvas, target, weights, peaks)  # (B, P) each
    forms = Forms.of(target) if forms is None else forms
    pick = torch.arange(batch, device=target.device)[:, None]
    lo, hi = size[0] * (w - 1) / 2, size[1] * (w - 1) / 2  # half-lengths in block pixels
    along, coherence = orientation(forms.structure[pick, :, rows, cols])  # (B, P) each
    turn = torch.rand(peaks, batch, generator=generator, dtype=target.dtype, device=generator.device).to(target.device).T
    direction = torch.where(coherence < 0.05, 2 * math.pi * turn, along)  # a random one where the target is flat
    colors, dist = reach(target, canvas, rows.to(target.dtype), cols.to(target.dtype), direction,
                         forms.colors[pick, :, rows, cols], hi)  # (B, P, 4, samples, 3), (B, P, 4)
    head, tail = colors[:, :, 1].mean(-2), colors[:, :, 0].mean(-2)  # (B, P, 3): the −direction and +direction halves
    paint = (head, tail) if brush.kinds.count("color") == 6 else (colors.mean((-3, -2)),)
    # the stroke spans the walks' stretch: centre halfway between their ends, half-extents clamped
    shift, across = (dist[..., 0] - dist[..., 1]) / 2, (dist[..., 2] - dist[..., 3]) / 2
    cx = cols + shift * torch.cos(direction) + across * -torch.sin(direction)
    cy = rows + shift * torch.sin(direction) + across * torch.cos(direction)
    scale = torch.tensor(scales, dtype=target.dtype, device=target.device)  # (L,)
    half = (scale * (dist[..., 0] + dist[..., 1])[..., None] / 2).clamp(lo, hi)  # (B, P, L)
    thick = ((dist[..., 2] + dist[..., 3]) / 2).clamp(max(0.5 * lo, 1.0), hi)[..., None].minimum(half)

    def each(value: Tensor) -> Tensor:
        """(B, P, …) -> (B·P·L, …): a peak's value for each of its lengths."""
        return value[:, :, None].expand(*half.shape, *value.shape[2:]).flatten(0, 2)

    x = _stroke(brush, each(cx / max(w - 1, 1)), each(cy / max(h - 1, 1)), each(direction), 2 * half.flatten() / (w - 1),
                2 * thick.flatten() / (w - 1), tuple(each(color) for color in paint))
    return x if peaks * len(scales) == 1 else x.view(batch, peaks * len(scales), -1)


def _stroke(brush: Brush, cx: Tensor, cy: Tensor, direction: Tensor, length: Tensor, thickness: Tensor,
            colors: tuple[Tensor, ...]) -> Tensor:
    """(B, d) parameters of strokes centred at (cx, cy) (fractions of the block), pointing at
    ``direction`` (radians), ``length`` and ``thickness`` fractions of the block width; ``colors``:
    one (B, 3) per colour of the brush, in parameter order."""

    def at(kind: str) -> list[int]:
        return [i for i, k in enumerate(brush.kinds) if k == kind]

    x = torch.full((len(cx), brush.d), 0.5, device=cx.device)
    xs, ys, sizes = at("x"), at("y"), at("size")
    spread = torch.linspace(-0.5, 0.5, len(xs), device=cx.device) if len(xs) > 1 else cx.new_zeros(1)  # points along the stroke
    x[:, xs] = cx[:, None] + spread * (length * torch.cos(direction))[:, None]
    x[:, ys] = cy[:, None] + spread * (length * torch.sin(direction))[:, None]
    rectangle = "angle" in brush.kinds
    # a rectangle's sizes are its length and thickness; a Bézier's are radii of W/4 units (SPEC §2)
    x[:, sizes] = torch.stack([length, thickness], 1)[:, : len(sizes)] if rectangle else (2 * thickness)[:, None]
    x[:, at("angle")] = ((direction / math.pi) % 1)[:, None]
    x[:, at("color")] = torch.cat(colors, 1)
    x[:, at("alpha")] = 1.0
    return x.clamp(0, 1)
