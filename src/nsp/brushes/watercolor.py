"""Watercolor ink: a quadratic Bézier swept by discs whose radius and colour go linearly from
(r0, C0) at P0 to (r2, C2) at P2, with uniform transparency A."""
from __future__ import annotations

import math

import numpy as np
import torch
from torch import Tensor

from nsp.brushes import bezier
from nsp.brushes.base import Pixels
from nsp.brushes.geometry import swept_discs
from nsp.colors import hex_color


class Watercolor(bezier.Bezier):
    def extent(self, x: Tensor, height: int, width: int) -> Tensor:
        return bezier.extent(x, torch.maximum(*self._radii(x, width))[:, 0], height, width)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        return bezier.distance_bound(x, pix, *self._radii(x, pix.width))

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        pts = bezier.control_points(x, pix.height, pix.width)
        r0, r2 = self._radii(x, pix.width)
        t, later = swept_discs(pts[:, 0], pts[:, 1], pts[:, 2], pix.px, pix.py, (r2 - r0)[:, 0])
        cov = coverage(self._disc_distance(pts, t, r0, r2, pix))
        c0, c2 = x[:, self.columns("R0", "B0"), None], x[:, self.columns("R2", "B2"), None]
        over = coverage(self._disc_distance(pts, later, r0, r2, pix))  # the later pass where a stroke curls, on top
        color = c0 + (c2 - c0) * (t + over * (later - t))[:, None]
        return color * (cov > 0)[:, None], x[:, self.alpha, None] * cov

    def svg(self, index: int, p: np.ndarray, height: int, width: int) -> tuple[str, str]:
        """The swept discs as pieces in order of t (more as the stroke turns, one if straight), each an
        outline and its end discs filled with its colour gradient, a later piece over an earlier one."""
        pts = bezier.svg_points(p, height, width)
        start, end = pts[1] - pts[0], pts[2] - pts[1]
        turn = math.atan2(abs(start[0] * end[1] - start[1] * end[0]), float(start @ end))
        pieces = 1 + math.ceil(turn / (math.pi / 8))
        r0, r2 = p[self.column("r0")] * width / 4, p[self.column("r2")] * width / 4
        ends = np.linspace(0, 1, pieces + 1)
        t = np.stack([np.linspace(a, b, max(3, math.ceil(32 / pieces) + 1)) for a, b in zip(ends[:-1], ends[1:])])[..., None]
        at = (1 - t) ** 2 * pts[0] + 2 * (1 - t) * t * pts[1] + t**2 * pts[2]  # (pieces, m, 2): every piece at once
        tangent = 2 * (1 - t) * start + 2 * t * end
        normal = np.stack([-tangent[..., 1], tangent[..., 0]], -1) / (np.linalg.norm(tangent, axis=-1, keepdims=True) + 1e-9)
        radius = r0 + (r2 - r0) * t
        outlines = np.concatenate([at + radius * normal, np.flip(at - radius * normal, 1)], 1)  # (pieces, 2m, 2)
        points = " ".join(["%.2f,%.2f"] * outlines.shape[1])  # one %-format a piece: the SVG of thousands of strokes is this loop
        c0, c2 = p[self.columns("R0", "B0")], p[self.columns("R2", "B2")]
        colors = [hex_color(c0 + (c2 - c0) * u) for u in ends]
        defs, body = [], []
        for k in range(pieces):
            (xa, ya), (xb, yb) = at[k, 0], at[k, -1]
            defs.append(f'<linearGradient id="g{index}_{k}" gradientUnits="userSpaceOnUse" x1="{xa:.3f}" y1="{ya:.3f}" '
                        f'x2="{xb:.3f}" y2="{yb:.3f}"><stop offset="0" stop-color="{colors[k]}"/>'
                        f'<stop offset="1" stop-color="{colors[k + 1]}"/></linearGradient>')
            body.append(f'<g fill="url(#g{index}_{k})"><polygon points="{points % tuple(outlines[k].ravel())}"/>'
                        f'<circle cx="{xa:.3f}" cy="{ya:.3f}" r="{radius[k, 0, 0]:.3f}"/><circle cx="{xb:.3f}" cy="{yb:.3f}" '
                        f'r="{radius[k, -1, 0]:.3f}"/></g>')
        return "".join(defs), f'<g opacity="{p[self.alpha]:.4f}">{"".join(body)}</g>'

    def centreline(self, p: np.ndarray, height: int, width: int) -> tuple[str, float, str]:
        """Its curve at its mean width (a pen has one: the discs' radii, r0 to r2, are averaged)."""
        (x0, y0), (x1, y1), (x2, y2) = bezier.svg_points(p, height, width)
        diameter = (p[self.column("r0")] + p[self.column("r2")]) * width / 4
        return f"M{x0:.2f} {y0:.2f} Q{x1:.2f} {y1:.2f} {x2:.2f} {y2:.2f}", diameter, "round"

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
)
