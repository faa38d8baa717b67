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
from nsp.engine.device import to_device
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
    turn = to_device(torch.rand(peaks, batch, generator=generator, dtype=target.dtype, device=generator.device),
                     target.device).T
    direction = torch.where(coherence < 0.05, 2 * math.pi * turn, along)  # a random one where the target is flat
    colors, dist = reach(target, canvas, rows.to(target.dtype), cols.to(target.dtype), direction,
                         forms.colors[pick, :, rows, cols], hi)  # (B, P, 4, samples, 3), (B, P, 4)
    head, tail = colors[:, :, 1].mean(-2), colors[:, :, 0].mean(-2)  # (B, P, 3): the −direction and +direction halves
    paint = (head, tail) if brush.kinds.count("color") == 6 else (colors.mean((-3, -2)),)
    # the stroke spans the walks' stretch: centre halfway between their ends, half-extents clamped
    shift, across = (dist[..., 0] - dist[..., 1]) / 2, (dist[..., 2] - dist[..., 3]) / 2
    cx = cols + shift * torch.cos(direction) + across * -torch.sin(direction)
    cy = rows + shift * torch.sin(direction) + across * torch.cos(direction)
    half = torch.stack([scale * (dist[..., 0] + dist[..., 1]) / 2 for scale in scales], -1).clamp(lo, hi)  # (B, P, L)
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
    points = brush.kinds.count("x")
    spread = [j / (points - 1) - 0.5 for j in range(points)] if points > 1 else [0.0]  # points along the stroke
    dx, dy = length * torch.cos(direction), length * torch.sin(direction)
    # a rectangle's sizes are its length and thickness; a Bézier's are radii of W/4 units (SPEC §2)
    sizes = [length, thickness] if "angle" in brush.kinds else [2 * thickness] * brush.kinds.count("size")
    values = {"x": iter([cx + s * dx for s in spread]), "y": iter([cy + s * dy for s in spread]), "size": iter(sizes),
              "angle": iter([(direction / math.pi) % 1]), "color": iter(torch.cat(colors, 1).unbind(1))}
    rest = {"alpha": torch.ones_like(cx)}  # opaque; any other parameter at 0.5
    x = torch.stack([next(values[kind]) if kind in values else rest.get(kind, torch.full_like(cx, 0.5))
                     for kind in brush.kinds], 1)  # built by columns: no index of host data, no copy a stroke
    return x.clamp(0, 1)
