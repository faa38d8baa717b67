"""Watercolor ink: a quadratic Bézier swept by discs whose radius and colour go linearly from
(r0, C0) at P0 to (r2, C2) at P2, with uniform transparency A."""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.brushes import bezier
from nsp.brushes.base import Brush, Pixels
from nsp.brushes.geometry import bezier_nearest


class Watercolor(Brush):
    def extent(self, x: Tensor, width: int, height: int) -> Tensor:
        return bezier.extent(x, torch.maximum(x[:, 6], x[:, 7]) * width / 4, width, height)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        return bezier.distance_bound(x, pix) - torch.maximum(x[:, 6], x[:, 7])[:, None] * pix.width / 4

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        pts = bezier.control_points(x, pix.width, pix.height)
        r0, r2 = x[:, 6:7] * pix.width / 4, x[:, 7:8] * pix.width / 4  # radii in pixels
        t = bezier_nearest(pts[:, 0], pts[:, 1], pts[:, 2], pix.px, pix.py, taper=(r2 - r0)[:, 0])
        bx, by = bezier.point(pts, t)
        sd = torch.sqrt((pix.px - bx) ** 2 + (pix.py - by) ** 2 + 1e-8) - (r0 + (r2 - r0) * t)
        cov = coverage(sd)
        c0, c2 = x[:, 8:11, None], x[:, 11:14, None]
        fg = (c0 + (c2 - c0) * t[:, None]) * (cov > 0)[:, None]
        return fg, x[:, 14:15] * cov


WATERCOLOR = Watercolor(
    name="watercolor",
    params=("x0", "y0", "x1", "y1", "x2", "y2", "r0", "r2", "R0", "G0", "B0", "R2", "G2", "B2", "A"),
    kinds=("x", "y", "x", "y", "x", "y", "size", "size") + ("color",) * 6 + ("alpha",),
    shape=tuple(range(8)),
    color=tuple(range(8, 14)),
    alpha=14,
    description="quadratic Bézier swept by discs; radius and colour interpolate from P0 to P2",
)
