"""Marker pen: a quadratic Bézier of constant thickness d and colour, drawn by a flat (square)
pen tip that follows the curve, with uniform transparency A."""
from __future__ import annotations

import numpy as np
import torch
from torch import Tensor

from nsp.brushes import bezier
from nsp.brushes.base import Brush, Pixels
from nsp.brushes.geometry import bezier_nearest
from nsp.brushes.svg import bezier_points
from nsp.colors import hex_color

_SQRT2 = 1.4143  # the square tip's corners reach √2·d from the trajectory's ends


class MarkerPen(Brush):
    def extent(self, x: Tensor, height: int, width: int) -> Tensor:
        return bezier.extent(x, _SQRT2 * x[:, self.column("d")] * width / 4, height, width)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        # The round body between the ends, and the square tip past either end, within √2·d of it.
        d = x[:, self.columns("d")] * pix.width / 4
        pts = bezier.control_points(x, pix.height, pix.width)
        ends = [torch.sqrt((pix.px - pts[:, i, :1]) ** 2 + (pix.py - pts[:, i, 1:]) ** 2 + 1e-8) for i in (0, 2)]
        return torch.minimum(bezier.distance_bound(x, pix, d, d), torch.minimum(*ends) - _SQRT2 * d)

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        pts = bezier.control_points(x, pix.height, pix.width)
        d = x[:, self.columns("d")] * pix.width / 4  # half thickness in pixels
        t = bezier_nearest(pts[:, 0], pts[:, 1], pts[:, 2], pix.px, pix.py)
        bx, by = bezier.point(pts, t)
        qx, qy = pix.px - bx, pix.py - by
        round_sd = torch.sqrt(qx * qx + qy * qy + 1e-8) - d
        # Past either end, the square tip: Chebyshev distance in the frame of the end's tangent.
        start, end = pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 1]
        chord = pts[:, 2] - pts[:, 0]
        start = torch.where(start.norm(dim=1, keepdim=True) > 1e-6, start, chord)
        end = torch.where(end.norm(dim=1, keepdim=True) > 1e-6, end, chord)
        ux = torch.where(t <= 0, start[:, :1], end[:, :1])
        uy = torch.where(t <= 0, start[:, 1:], end[:, 1:])
        norm = torch.sqrt(ux * ux + uy * uy + 1e-12)
        along, across = (qx * ux + qy * uy) / norm, (qy * ux - qx * uy) / norm
        cap_sd = torch.maximum(along.abs(), across.abs()) - d
        sd = torch.where((t <= 0) | (t >= 1), cap_sd, round_sd)
        cov = coverage(sd)
        fg = x[:, self.columns("R", "B"), None] * (cov > 0)[:, None]
        return fg, x[:, self.alpha, None] * cov

    def svg(self, index: int, p: np.ndarray, height: int, width: int) -> tuple[str, str]:
        (x0, y0), (x1, y1), (x2, y2) = bezier_points(p, height, width)
        return "", (
            f'<path d="M{x0:.3f} {y0:.3f} Q{x1:.3f} {y1:.3f} {x2:.3f} {y2:.3f}" fill="none" '
            f'stroke="{hex_color(p[self.columns("R", "B")])}" stroke-width="{p[self.column("d")] * width / 2:.3f}" '
            f'stroke-linecap="square" opacity="{p[self.alpha]:.4f}"/>'
        )

    def from_reference(self, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, width: int) -> tuple[Brush, np.ndarray]:
        return self, bezier.from_reference(ctt, ctt[:, self.columns("d")], color, alpha, width)  # its 2nd radius is unused


MARKERPEN = MarkerPen(
    name="markerpen",
    params=bezier.CONTROL + ("d", "R", "G", "B", "A"),
    kinds=("x", "y", "x", "y", "x", "y", "size", "color", "color", "color", "alpha"),
    shape=tuple(range(7)),
    color=(7, 8, 9),
    alpha=10,
    description="quadratic Bézier of constant thickness with a flat, square pen tip",
    reference=(8, 3),
)
