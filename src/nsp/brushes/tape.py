"""Colour tape: a solid, opaque rotated rectangle (8-bit / low-poly art)."""
from __future__ import annotations

import math

import torch
from torch import Tensor

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.geometry import box, rotated_frame, to_pixels


def rectangle(x: Tensor, pix: Pixels) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """Frame and half extents of the rectangle x[:, 0:5] = x, y, w, h, θ.

    Returns (along, across) pixel coordinates in the stroke's frame, each (P, N), and the half
    extents (P,) in pixels; w and h are fractions of the canvas width.
    """
    cx, cy = to_pixels(x[:, 0], x[:, 1], pix.width, pix.height)
    along, across = rotated_frame(pix.px, pix.py, cx, cy, x[:, 4])
    return along, across, x[:, 2] * pix.width / 2, x[:, 3] * pix.width / 2


def rectangle_extent(x: Tensor, width: int, height: int) -> Tensor:
    """Boxes (P, 4) around the rotated rectangles x[:, 0:5] = x, y, w, h, θ, in pixels."""
    cx, cy = to_pixels(x[:, 0], x[:, 1], width, height)
    half_w, half_h = x[:, 2] * width / 2, x[:, 3] * width / 2
    cos, sin = torch.cos(x[:, 4] * math.pi).abs(), torch.sin(x[:, 4] * math.pi).abs()
    ex, ey = half_w * cos + half_h * sin, half_w * sin + half_h * cos
    return torch.stack([cx - ex, cy - ey, cx + ex, cy + ey], 1)


class Tape(Brush):
    def extent(self, x: Tensor, width: int, height: int) -> Tensor:
        return rectangle_extent(x, width, height)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        return box(*rectangle(x, pix))

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        cov = coverage(box(*rectangle(x, pix)))
        return x[:, 5:8, None] * (cov > 0)[:, None], cov


TAPE = Tape(
    name="tape",
    params=("x", "y", "w", "h", "theta", "R", "G", "B"),
    kinds=("x", "y", "size", "size", "angle", "color", "color", "color"),
    shape=(0, 1, 2, 3, 4),
    color=(5, 6, 7),
    alpha=None,
    description="solid rotated rectangle",
)
