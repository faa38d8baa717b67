"""Watercolor ink: a quadratic Bézier swept by discs whose radius and colour go linearly from
(r0, C0) at P0 to (r2, C2) at P2, with uniform transparency A."""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.brushes import bezier
from nsp.brushes.base import Brush, Pixels
from nsp.engine.geometry import project_polyline


class Watercolor(Brush):
    def radii(self, x: Tensor, pix: Pixels) -> tuple[Tensor, Tensor]:
        """Radii at P0 and P2 in pixels (r · W/4): (P,), (P,)."""
        return x[:, 6] * pix.width / 4, x[:, 7] * pix.width / 4

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        r0, r2 = self.radii(x, pix)
        return bezier.distance(bezier.trajectory(x, pix), pix) - torch.maximum(r0, r2)[:, None]

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        points = bezier.trajectory(x, pix)
        along, perp, length, s = project_polyline(points, pix.px, pix.py)
        k = points.shape[1] - 1
        t = (torch.arange(k, device=x.device, dtype=x.dtype) + s) / k  # (P, N, K)
        r0, r2 = self.radii(x, pix)
        radius = r0[:, None, None] + (r2 - r0)[:, None, None] * t
        excess = torch.maximum(-along, along - length).clamp(min=0)
        sd_k = torch.sqrt(perp**2 + excess**2 + 1e-8) - radius
        sd, nearest = sd_k.min(-1)
        t_near = t.gather(-1, nearest[..., None])[..., 0]  # (P, N)
        c0, c2 = x[:, 8:11, None], x[:, 11:14, None]
        cov = coverage(sd)
        fg = (c0 + (c2 - c0) * t_near[:, None]) * (cov > 0)[:, None]
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
