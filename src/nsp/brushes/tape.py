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
from nsp.colors import hex_color

RECTANGLE = ("x", "y", "w", "h", "theta")  # the parameters every rectangle brush (tape, oil paint) starts with


def rectangle(x: Tensor, pix: Pixels) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """The rectangles (:data:`RECTANGLE`) of strokes x (P, d): pixel coordinates (along, across) in
    each stroke's frame, (P, N) each, and its half extents (half_w, half_h), (P,) each, in pixels."""
    cx, cy, w, h, theta = (x[:, i] for i in range(len(RECTANGLE)))
    cx, cy = to_pixels(cx, cy, pix.height, pix.width)
    along, across = rotated_frame(pix.px, pix.py, cx, cy, theta)
    return along, across, w * pix.width / 2, h * pix.width / 2


class Rectangle(Brush):
    """A brush of rotated rectangles (:data:`RECTANGLE`): their extent and distance bound."""

    def extent(self, x: Tensor, height: int, width: int) -> Tensor:
        cx, cy, w, h, theta = (x[:, i] for i in range(len(RECTANGLE)))
        cx, cy = to_pixels(cx, cy, height, width)
        half_w, half_h = w * width / 2, h * width / 2
        cos, sin = torch.cos(theta * math.pi).abs(), torch.sin(theta * math.pi).abs()
        ex, ey = half_w * cos + half_h * sin, half_w * sin + half_h * cos
        return torch.stack([cx - ex, cy - ey, cx + ex, cy + ey], 1)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        return box(*rectangle(x, pix))

    def centreline(self, p: np.ndarray, height: int, width: int) -> list[tuple[str, float, str]]:
        """Its long axis, as wide as its short side, ends cut square (oil's head and tail as tape's)."""
        cx, cy, w, h, theta = p[:len(RECTANGLE)]
        cx, cy, w, h = cx * (width - 1), cy * (height - 1), w * width, h * width
        angle = theta * math.pi + (0 if w >= h else math.pi / 2)  # SVG's rotate(θ·180°), as svg() draws it
        dx, dy = max(w, h) / 2 * math.cos(angle), max(w, h) / 2 * math.sin(angle)
        return [(f"M{cx - dx:.2f} {cy - dy:.2f} L{cx + dx:.2f} {cy + dy:.2f}", min(w, h), "butt")]


class Tape(Rectangle):
    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        cov = coverage(box(*rectangle(x, pix)))
        alpha = cov if self.alpha is None else x[:, self.alpha, None] * cov
        return x[:, self.columns("R", "B"), None] * (cov > 0)[:, None], alpha

    def svg(self, index: int, p: np.ndarray, height: int, width: int) -> tuple[str, str]:
        cx, cy, w, h, theta = p[:len(RECTANGLE)]
        cx, cy, w, h = cx * (width - 1), cy * (height - 1), max(w * width, 1e-3), max(h * width, 1e-3)
        opacity = "" if self.alpha is None else f' opacity="{p[self.alpha]:.4f}"'
        frame = f'translate({cx:.3f} {cy:.3f}) rotate({theta * 180:.3f}) scale({w:.3f} {h:.3f})'  # of the unit square
        fill = hex_color(p[self.columns("R", "B")])
        return "", f'<rect x="-0.5" y="-0.5" width="1" height="1" fill="{fill}"{opacity} transform="{frame}"/>'

    def from_reference(self, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, width: int) -> tuple[Brush, np.ndarray]:
        sizes = 2 * (1 + ctt[:, self.columns("w", "h")] * width / 4) / width  # half extents 1 + w·W/4 px -> extent / W
        turn = np.mod(1 - ctt[:, self.columns("theta")], 1)  # its rectangles turn counter-clockwise, nsp's clockwise
        brush = self if (alpha >= 1).all() else TRANSLUCENT_TAPE  # its rectangles blend with their alpha
        parts = [ctt[:, self.columns("x", "y")], sizes, turn, color] + ([] if brush.alpha is None else [alpha])
        return brush, np.clip(np.concatenate(parts, 1), 0, 1)


TAPE = Tape(
    name="tape", params=RECTANGLE + ("R", "G", "B"), kinds=("x", "y", "size", "size", "angle") + ("color",) * 3,
    shape=(0, 1, 2, 3, 4), color=(5, 6, 7), description="solid rotated rectangle", reference=(5, 3),
)
TRANSLUCENT_TAPE = dataclasses.replace(
    TAPE, params=TAPE.params + ("A",), kinds=TAPE.kinds + ("alpha",), alpha=8,
    description="rotated rectangle of uniform transparency A (reference rectangle files)",
)
