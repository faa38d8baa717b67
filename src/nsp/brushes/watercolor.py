"""Watercolor: a quadratic Bézier swept by discs whose radius and colour go linearly from (r0, C0)
at P0 to (r2, C2) at P2, with uniform transparency A; its pigment darkens the rim and granulates on
the paper (:mod:`nsp.brushes.pigment`)."""
from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np
import torch
from torch import Tensor

from nsp.brushes import bezier, pigment
from nsp.brushes.base import Pixels
from nsp.brushes.detail import Detailed
from nsp.brushes.geometry import swept_discs

PIECES = 4  # a plotter's pen has one width: the curve in pieces, each its own width


@dataclasses.dataclass(frozen=True, eq=False)
class Watercolor(Detailed, bezier.Bezier):
    svg_painted: ClassVar[bool] = True  # its paint has no vector form

    def parts(self, width: int | Tensor) -> tuple[bool, ...]:
        return pigment.wash_parts(width)

    def extent(self, x: Tensor, height: int, width: int) -> Tensor:
        return bezier.extent(x, torch.maximum(*self._radii(x, width))[:, 0], height, width)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        return bezier.distance_bound(x, pix, *self._radii(x, pix.width))

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        pts = bezier.control_points(x, pix.height, pix.width)
        r0, r2 = self._radii(x, pix.width)
        t, later = swept_discs(pts[:, 0], pts[:, 1], pts[:, 2], pix.px, pix.py, (r2 - r0)[:, 0])
        inside = self._disc_distance(pts, t, r0, r2, pix)
        cov = coverage(inside)
        c0, c2 = x[:, self.columns("R0", "B0"), None], x[:, self.columns("R2", "B2"), None]
        over = coverage(self._disc_distance(pts, later, r0, r2, pix))  # the later pass where a stroke curls, on top
        color = c0 + (c2 - c0) * (t + over * (later - t))[:, None]
        density = pigment.wash(inside, r0 + (r2 - r0) * t, pix.px, pix.py, pix.width, self._parts(pix.width))
        if density is not None:
            color = pigment.tint(color, density)
        return color * (cov > 0)[:, None], x[:, self.alpha, None] * cov

    def centreline(self, p: np.ndarray, height: int, width: int) -> list[tuple[str, float, str]]:
        """Its curve in :data:`PIECES` pieces, each as wide as the discs at its middle (r0 to r2 along it)."""
        pts, r0, r2 = bezier.svg_points(p, height, width), p[self.column("r0")], p[self.column("r2")]
        ends = np.linspace(0, 1, PIECES + 1)
        return [(bezier.svg_path(bezier.piece(pts, a, b)), (r0 + (r2 - r0) * (a + b) / 2) * width / 2, "round")
                for a, b in zip(ends[:-1], ends[1:])]

    def _radii(self, x: Tensor, width: int | Tensor) -> tuple[Tensor, Tensor]:
        """r0, r2 of strokes x (P, d) in pixels on a canvas ``width`` px wide: (P, 1) each."""
        return x[:, self.columns("r0")] * width / 4, x[:, self.columns("r2")] * width / 4

    @staticmethod
    def _disc_distance(pts: Tensor, t: Tensor, r0: Tensor, r2: Tensor, pix: Pixels) -> Tensor:
        """Signed distance (P, N) from each pixel to the disc at t (P, N) of radius r0 + (r2 − r0)·t."""
        bx, by = bezier.point(pts, t)
        return torch.sqrt((pix.px - bx) ** 2 + (pix.py - by) ** 2 + 1e-8) - (r0 + (r2 - r0) * t)


WATERCOLOR = Watercolor(
    name="watercolor", params=bezier.CONTROL + ("r0", "r2", "R0", "G0", "B0", "R2", "G2", "B2", "A"), alpha=14,
    kinds=("x", "y") * 3 + ("size",) * 2 + ("color",) * 6 + ("alpha",), shape=tuple(range(8)), color=tuple(range(8, 14)),
    reference=(8, 6), description="quadratic Bézier swept by discs; radius and colour interpolate from P0 to P2",
    glaze=0.1,  # overlapping strokes darken a little (brush.glaze=); benchmarks/glaze.py: no PSNR cost at 500 strokes
)
