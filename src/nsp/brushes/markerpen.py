"""Marker pen: a quadratic Bézier of constant thickness d and colour, drawn by a flat (square)
pen tip that follows the curve, with uniform transparency A; its ink streaks along the path and
pools at the ends (:mod:`nsp.brushes.pigment`)."""
from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np
import torch
from torch import Tensor

from nsp.brushes import bezier, pigment
from nsp.brushes.base import Pixels
from nsp.brushes.detail import Detailed
from nsp.brushes.geometry import bezier_nearest

_SQRT2 = 1.4143  # the square tip's corners reach √2·d from the trajectory's ends


@dataclasses.dataclass(frozen=True, eq=False)
class MarkerPen(Detailed, bezier.Bezier):
    svg_painted: ClassVar[bool] = True  # its paint has no vector form

    def parts(self, width: int | Tensor) -> tuple[bool, ...]:
        return pigment.streak_parts(width)

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
        color = x[:, self.columns("R", "B"), None]
        if any(parts := self._parts(pix.width)):
            # In the frame of the path at t (B'(t) / 2), and along it: its length lies between the control
            # polygon's and the chord's.
            ux, uy = torch.lerp(start[:, :1], end[:, :1], t), torch.lerp(start[:, 1:], end[:, 1:], t)
            norm = torch.sqrt(ux * ux + uy * uy + 1e-12)
            along, across = (qx * ux + qy * uy) / norm, (qy * ux - qx * uy) / norm
            length = (start.norm(dim=1, keepdim=True) + end.norm(dim=1, keepdim=True) + chord.norm(dim=1, keepdim=True)) / 2
            key = pix.key if pix.key is not None else torch.zeros_like(d, dtype=torch.int64)
            color = pigment.tint(color, pigment.marker(t * length + along, across, length, d, key, pix.width, parts))
        return color * (cov > 0)[:, None], x[:, self.alpha, None] * cov

    def centreline(self, p: np.ndarray, height: int, width: int) -> list[tuple[str, float, str]]:
        return [(bezier.svg_path(bezier.svg_points(p, height, width)), p[self.column("d")] * width / 2, "square")]


MARKERPEN = MarkerPen(
    name="markerpen", params=bezier.CONTROL + ("d", "R", "G", "B", "A"), shape=tuple(range(7)), color=(7, 8, 9),
    kinds=("x", "y") * 3 + ("size",) + ("color",) * 3 + ("alpha",), alpha=10, reference=(8, 3),
    glaze=0.1,  # overlapping strokes darken a little (brush.glaze=); benchmarks/glaze.py: no PSNR cost at 500 strokes
    description="quadratic Bézier of constant thickness with a flat, square pen tip",
)
