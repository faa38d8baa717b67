"""Marker pen: a quadratic Bézier of constant thickness d and colour, drawn by a flat (square)
pen tip that follows the curve, with uniform transparency A."""
from __future__ import annotations

import numpy as np
import torch
from torch import Tensor

from nsp.brushes import bezier
from nsp.brushes.base import Pixels
from nsp.brushes.geometry import bezier_nearest
from nsp.colors import hex_color

_SQRT2 = 1.4143  # the square tip's corners reach √2·d from the trajectory's ends


class MarkerPen(bezier.Bezier):
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
        start, end, chord = pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 1], pts[:, 2] - pts[:, 0]
        start = torch.where(start.norm(dim=1, keepdim=True) > 1e-6, start, chord)
        end = torch.where(end.norm(dim=1, keepdim=True) > 1e-6, end, chord)
        ux, uy = torch.where(t <= 0, start[:, :1], end[:, :1]), torch.where(t <= 0, start[:, 1:], end[:, 1:])
        norm = torch.sqrt(ux * ux + uy * uy + 1e-12)
        along, across = (qx * ux + qy * uy) / norm, (qy * ux - qx * uy) / norm
        cap_sd = torch.maximum(along.abs(), across.abs()) - d
        cov = coverage(torch.where((t <= 0) | (t >= 1), cap_sd, round_sd))
        return x[:, self.columns("R", "B"), None] * (cov > 0)[:, None], x[:, self.alpha, None] * cov

    def svg(self, index: int, p: np.ndarray, height: int, width: int) -> tuple[str, str]:
        (x0, y0), (x1, y1), (x2, y2) = bezier.svg_points(p, height, width)
        return "", (
            f'<path d="M{x0:.3f} {y0:.3f} Q{x1:.3f} {y1:.3f} {x2:.3f} {y2:.3f}" fill="none" '
            f'stroke="{hex_color(p[self.columns("R", "B")])}" stroke-width="{p[self.column("d")] * width / 2:.3f}" '
            f'stroke-linecap="square" opacity="{p[self.alpha]:.4f}"/>'
        )

    def centreline(self, p: np.ndarray, height: int, width: int) -> tuple[str, float, str]:
        (x0, y0), (x1, y1), (x2, y2) = bezier.svg_points(p, height, width)
        return f"M{x0:.2f} {y0:.2f} Q{x1:.2f} {y1:.2f} {x2:.2f} {y2:.2f}", p[self.column("d")] * width / 2, "square"


MARKERPEN = MarkerPen(
    name="markerpen", params=bezier.CONTROL + ("d", "R", "G", "B", "A"), shape=tuple(range(7)), color=(7, 8, 9),
    kinds=("x", "y") * 3 + ("size",) + ("color",) * 3 + ("alpha",), alpha=10, reference=(8, 3),
    description="quadratic Bézier of constant thickness with a flat, square pen tip",
)
