"""Marker pen: a quadratic Bézier of constant thickness d and colour, drawn by a flat (square)
pen tip that follows the curve, with uniform transparency A."""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.brushes import bezier
from nsp.brushes.base import Brush, Pixels
from nsp.engine.geometry import project_polyline


class MarkerPen(Brush):
    def half_width(self, x: Tensor, pix: Pixels) -> Tensor:
        """Half thickness in pixels (d · W/4): (P,)."""
        return x[:, 6] * pix.width / 4

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        # The square caps reach √2·d from the trajectory's ends.
        return bezier.distance(bezier.trajectory(x, pix), pix) - 1.4143 * self.half_width(x, pix)[:, None]

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        points = bezier.trajectory(x, pix)
        along, perp, length, _ = project_polyline(points, pix.px, pix.py)
        d = self.half_width(x, pix)[:, None, None]
        before, after = -along, along - length
        # Square caps: past either end of the trajectory the tip's square extends d further.
        cap = torch.zeros_like(along, dtype=torch.bool)
        cap[..., 0] = before[..., 0] > 0
        cap[..., -1] |= after[..., -1] > 0
        excess = torch.maximum(before, after).clamp(min=0)
        round_sd = torch.sqrt(perp**2 + excess**2 + 1e-8) - d
        cap_sd = torch.maximum(perp, excess) - d
        sd = torch.where(cap, cap_sd, round_sd).amin(-1)
        cov = coverage(sd)
        fg = x[:, 7:10, None] * (cov > 0)[:, None]
        return fg, x[:, 10:11] * cov


MARKERPEN = MarkerPen(
    name="markerpen",
    params=("x0", "y0", "x1", "y1", "x2", "y2", "d", "R", "G", "B", "A"),
    kinds=("x", "y", "x", "y", "x", "y", "size", "color", "color", "color", "alpha"),
    shape=tuple(range(7)),
    color=(7, 8, 9),
    alpha=10,
    description="quadratic Bézier of constant thickness with a flat, square pen tip",
)
