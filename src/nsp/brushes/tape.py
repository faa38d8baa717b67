"""Colour tape: a solid, opaque rotated rectangle (8-bit / low-poly art). Its translucent variant
(a tenth parameter, A) holds the reference implementation's semi-transparent rectangles."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import torch
from torch import Tensor

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.geometry import box, rotated_frame, to_pixels
from nsp.brushes.svg import UNIT, rectangle_frame
from nsp.colors import hex_color


def rectangle(x: Tensor, pix: Pixels) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """Frame and half extents of the rectangle x[:, 0:5] = x, y, w, h, θ.

    Returns (along, across) pixel coordinates in the stroke's frame, each (P, N), and the half
    extents (P,) in pixels; w and h are fractions of the canvas width.
    """
    cx, cy = to_pixels(x[:, 0], x[:, 1], pix.height, pix.width)
    along, across = rotated_frame(pix.px, pix.py, cx, cy, x[:, 4])
    return along, across, x[:, 2] * pix.width / 2, x[:, 3] * pix.width / 2


def rectangle_extent(x: Tensor, height: int, width: int) -> Tensor:
    """Boxes (P, 4) around the rotated rectangles x[:, 0:5] = x, y, w, h, θ, in pixels."""
    cx, cy = to_pixels(x[:, 0], x[:, 1], height, width)
    half_w, half_h = x[:, 2] * width / 2, x[:, 3] * width / 2
    cos, sin = torch.cos(x[:, 4] * math.pi).abs(), torch.sin(x[:, 4] * math.pi).abs()
    ex, ey = half_w * cos + half_h * sin, half_w * sin + half_h * cos
    return torch.stack([cx - ex, cy - ey, cx + ex, cy + ey], 1)


class Tape(Brush):
    def extent(self, x: Tensor, height: int, width: int) -> Tensor:
        return rectangle_extent(x, height, width)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        return box(*rectangle(x, pix))

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        cov = coverage(box(*rectangle(x, pix)))
        alpha = cov if self.alpha is None else x[:, self.alpha, None] * cov
        return x[:, 5:8, None] * (cov > 0)[:, None], alpha

    def svg(self, index: int, p: np.ndarray, height: int, width: int) -> tuple[str, str]:
        opacity = "" if self.alpha is None else f' opacity="{p[self.alpha]:.4f}"'
        return "", f'<rect {UNIT} fill="{hex_color(p[5:8])}"{opacity} {rectangle_frame(p, height, width)}/>'

    def from_reference(self, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, width: int) -> tuple[Brush, np.ndarray]:
        sizes = 2 * (1 + ctt[:, 2:4] * width / 4) / width  # half extents 1 + w·W/4 px -> full extent / W
        turn = np.mod(1 - ctt[:, 4:5], 1)  # its rectangles turn counter-clockwise on screen by θ·π, nsp's clockwise
        brush = self if (alpha >= 1).all() else TRANSLUCENT_TAPE  # its rectangles blend with their alpha
        parts = [ctt[:, :2], sizes, turn, color] + ([] if brush.alpha is None else [alpha])
        return brush, np.clip(np.concatenate(parts, 1), 0, 1)


TAPE = Tape(
    name="tape",
    params=("x", "y", "w", "h", "theta", "R", "G", "B"),
    kinds=("x", "y", "size", "size", "angle", "color", "color", "color"),
    shape=(0, 1, 2, 3, 4),
    color=(5, 6, 7),
    alpha=None,
    description="solid rotated rectangle",
    reference=(5, 3),
)
TRANSLUCENT_TAPE = dataclasses.replace(
    TAPE, params=TAPE.params + ("A",), kinds=TAPE.kinds + ("alpha",), alpha=8,
    description="rotated rectangle of uniform transparency A (reference rectangle files)",
)
