"""Shared geometry of the Bézier brushes (watercolor, markerpen)."""
from __future__ import annotations

import math

import numpy as np
import torch
from torch import Tensor

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.geometry import to_pixels

CONTROL = ("x0", "y0", "x1", "y1", "x2", "y2")  # P0, P1, P2: the parameters every Bézier brush starts with
_XS, _YS = slice(0, len(CONTROL), 2), slice(1, len(CONTROL), 2)  # their x0, x1, x2 and y0, y1, y2


def control_points(x: Tensor, height: int, width: int) -> Tensor:
    """P0, P1, P2 (:data:`CONTROL`) of strokes x (P, d) in pixels: (P, 3, 2)."""
    return torch.stack(to_pixels(x[:, _XS], x[:, _YS], height, width), -1)


def svg_points(p: np.ndarray, height: int, width: int) -> np.ndarray:
    """P0, P1, P2 of one stroke's parameters p (d,) in pixels, for its SVG element: (3, 2)."""
    return p[:len(CONTROL)].reshape(3, 2) * [width - 1, height - 1]


def piece(pts: np.ndarray, a: float, b: float) -> np.ndarray:
    """The control points (3, 2) of the part from t = a to t = b of the curve ``pts`` (3, 2): B(a), the
    blossom B(a, b), B(b)."""
    p0, p1, p2 = pts
    return np.stack([(1 - a) ** 2 * p0 + 2 * (1 - a) * a * p1 + a * a * p2,
                     (1 - a) * (1 - b) * p0 + ((1 - a) * b + a * (1 - b)) * p1 + a * b * p2,
                     (1 - b) ** 2 * p0 + 2 * (1 - b) * b * p1 + b * b * p2])


def svg_path(pts: np.ndarray) -> str:
    """SVG path data of the curve ``pts`` (3, 2) in pixels."""
    (x0, y0), (x1, y1), (x2, y2) = pts
    return f"M{x0:.2f} {y0:.2f} Q{x1:.2f} {y1:.2f} {x2:.2f} {y2:.2f}"


def point(pts: Tensor, t: Tensor) -> tuple[Tensor, Tensor]:
    """B(t) for control points (P, 3, 2) at parameters t (P, N): x, y each (P, N)."""
    p0, p1, p2 = (pts[:, i, :, None] for i in range(3))
    b = (1 - t)[:, None] ** 2 * p0 + 2 * ((1 - t) * t)[:, None] * p1 + (t * t)[:, None] * p2
    return b[:, 0], b[:, 1]


def extent(x: Tensor, reach: Tensor, height: int, width: int) -> Tensor:
    """Boxes (P, 4) around the control polygon (which holds the curve), grown by ``reach`` (P,) px."""
    pts = control_points(x, height, width)
    return torch.cat([pts.amin(1) - reach[:, None], pts.amax(1) + reach[:, None]], 1)


def distance_bound(x: Tensor, pix: Pixels, r0: Tensor, r2: Tensor) -> Tensor:
    """A 1-Lipschitz lower bound of the distance from each pixel to the discs swept along the curve,
    their radius going linearly from r0 at P0 to r2 at P2 ((P, 1) px each): (P, N). By the polyline
    through B(k/K): a quadratic leaves its chords by at most |P0 − 2P1 + P2|/(4K²) (K keeps that below
    about a pixel), and along the piece of curve a chord spans, the radius is at most its ends' larger."""
    pts = control_points(x, pix.height, pix.width)
    k = int(min(32, max(8, math.ceil(math.sqrt(max(pix.height, pix.width)) / 1.4))))
    t = torch.linspace(0, 1, k + 1, device=x.device, dtype=x.dtype)  # (K + 1,)
    p0, p1, p2, u = pts[:, 0, None], pts[:, 1, None], pts[:, 2, None], t[None, :, None]
    line = (1 - u) ** 2 * p0 + 2 * (1 - u) * u * p1 + u**2 * p2  # B(k/K): (P, K + 1, 2)
    start, end = line[:, None, :-1], line[:, None, 1:]  # each segment's: (P, 1, K, 2)
    chord = end - start
    length = torch.sqrt((chord**2).sum(-1) + 1e-8)  # (P, 1, K)
    ux, uy = chord[..., 0] / length, chord[..., 1] / length
    dx, dy = pix.px[..., None] - start[..., 0], pix.py[..., None] - start[..., 1]  # (P, N, K)
    along, perp = dx * ux + dy * uy, (dx * uy - dy * ux).abs()  # from each segment's start, and off its line
    excess = torch.maximum(-along, along - length).clamp(min=0)
    chord_error = (pts[:, 0] - 2 * pts[:, 1] + pts[:, 2]).norm(dim=1) / (4 * k * k)
    radius = r0 + (r2 - r0) * t  # (P, K + 1)
    reach = torch.maximum(radius[:, :-1], radius[:, 1:])[:, None]  # (P, 1, K): the most on each chord
    return (torch.sqrt(perp**2 + excess**2 + 1e-8) - reach).amin(-1) - chord_error[:, None]


class Bezier(Brush):
    """A brush of quadratic Béziers: :data:`CONTROL`, then their radii (the rest of its shape)."""

    def from_reference(self, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, width: int) -> tuple[Brush, np.ndarray]:
        """The reference's control point P1 is relative, x1' = x0 + (x2 − x0)·x1 (likewise y), and its
        radii are 1 + r·W/4 pixels (the marker pen's second radius is unused)."""
        x0, y0, x1, y1, x2, y2 = ctt[:, :len(CONTROL)].T
        shape = np.stack([x0, y0, x0 + (x2 - x0) * x1, y0 + (y2 - y0) * y1, x2, y2], 1)
        sizes = (1 + ctt[:, len(CONTROL):len(self.shape)] * width / 4) / (width / 4)
        return self, np.clip(np.concatenate([shape, sizes, color, alpha], 1), 0, 1)
