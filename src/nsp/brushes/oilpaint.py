"""Oil paint: an opaque rotated rectangle carrying a bristle texture, its colour blending from
(R0, G0, B0) at the head to (R2, G2, B2) at the tail."""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
from typing import ClassVar
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes import bristles
from nsp.brushes.base import Brush, Pixels
from nsp.brushes.detail import Detailed
from nsp.brushes.tape import RECTANGLE, Rectangle, rectangle
from nsp.brushes.texture import EMBEDDED, load_texture
from nsp.brushes.geometry import box

_OPAQUE = 0.4  # a user texture's values above this are fully covered with paint


def sample(texture: Tensor, u: Tensor, v: Tensor) -> Tensor:
    """Bilinear texture values (P, N) at (u, v) ∈ [0, 1]² (P, N) of a (1, 1, h, w) texture."""
    grid = torch.stack([2 * u - 1, 2 * v - 1], -1)[:, None]  # (P, 1, N, 2)
    return F.grid_sample(texture.expand(u.shape[0], -1, -1, -1), grid, align_corners=True)[:, 0, 0]


@functools.cache
def _digest(source: str) -> str:
    """A user texture's identity: its bytes (a file's, or an embedded image's), hashed."""
    data = source.encode() if source.startswith(EMBEDDED) else Path(source).expanduser().read_bytes()
    return hashlib.sha1(data).hexdigest()[:12]


@dataclasses.dataclass(frozen=True, eq=False)
class OilPaint(Detailed, Rectangle):
    """Oil paint whose paint is the bristle model (:mod:`nsp.brushes.bristles`), or a user's grayscale image
    stretched over each stroke (``texture_path``, :mod:`nsp.brushes.texture`); ``impasto`` lights its relief."""

    svg_painted: ClassVar[bool] = True  # its paint has no vector form
    impasto: bool = True

    def parts(self, width: int | Tensor) -> tuple[bool, ...]:
        return bristles.detail(width)

    def sized(self, width: int) -> "OilPaint | None":
        return None if self.texture_path else super().sized(width)

    def varies(self, width: int) -> bool:
        return self.texture_path is None and super().varies(width)

    @property
    def variant(self) -> str:
        texture = _digest(self.texture_path) if self.texture_path else "own"
        detail = super().variant
        return texture + ("" if self.impasto else "-flat") + (detail and "-" + detail)

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        along, across, half_w, half_h = rectangle(x, pix)
        light = bristles.light_across(x[:, self.column("theta")]) if self.impasto else None
        length, s = 2 * half_w, along + half_w[:, None]  # s: pixels from the head
        u = (s / length.clamp(min=0.5)[:, None]).clamp(0, 1)  # 0 at the head, 1 at the tail
        edge = box(along, across, half_w, half_h)
        if self.texture_path is None:
            key = pix.key if pix.key is not None else torch.zeros_like(along[:, :1], dtype=torch.int64)
            paint = bristles.surface(s, across, u, length, half_h, key, pix.width, light, self._parts(pix.width))
        else:
            paint = self._textured(u, across / (2 * half_h.clamp(min=0.5))[:, None] + 0.5, pix.width, light)
        alpha = coverage(torch.maximum(edge, paint.outline)) * paint.cover
        c0, c2 = x[:, self.columns("R0", "B0"), None], x[:, self.columns("R2", "B2"), None]
        color = c0 + (c2 - c0) * u[:, None]
        if paint.shade is not None:
            color = color * paint.shade[:, None]
        return color * (alpha > 0)[:, None], alpha

    def _textured(self, u: Tensor, v: Tensor, width: int, light) -> bristles.Surface:
        """A user's texture as paint: its values give the cover and, as a height, the relief (its outline: −∞,
        the rectangle alone); on a canvas narrower than itself, area-downsampled to its width (a mipmap level)."""
        key = (str(u.device), u.dtype, width)
        if (texture := self._cache.get(key)) is None:
            texture = load_texture(self.texture_path)[None, None].to(device=u.device, dtype=u.dtype)
            if width < texture.shape[-1]:
                scale = max(width, 16) / texture.shape[-1]
                size = (max(4, round(texture.shape[-2] * scale)), max(16, round(texture.shape[-1] * scale)))
                texture = F.interpolate(texture, size=size, mode="area")
            self._cache[key] = texture
        value = sample(texture, u, v)
        shade = 0.7 + 0.3 * value
        if light is not None:
            du, dv = 1 / texture.shape[-1], 1 / texture.shape[-2]
            slope = ((sample(texture, u + du, v) - sample(texture, u - du, v)) * light[0]
                     + (sample(texture, u, v + dv) - sample(texture, u, v - dv)) * light[1])
            shade = shade * (1 - bristles.LIT * 2 * slope)
        return bristles.Surface((value / _OPAQUE).clamp(0, 1), shade, torch.full_like(value, -math.inf))

    def from_reference(self, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, width: int) -> tuple[Brush, np.ndarray]:
        sizes = (1 + ctt[:, self.columns("w", "h")] * width) / width  # extents 1 + w·W px -> fraction of W; its alpha is unused
        parts = [ctt[:, self.columns("x", "y")], sizes, ctt[:, self.columns("theta")], color]
        return self, np.clip(np.concatenate(parts, 1), 0, 1)


OILPAINT = OilPaint(
    name="oilpaint", params=RECTANGLE + ("R0", "G0", "B0", "R2", "G2", "B2"),
    kinds=("x", "y", "size", "size", "angle") + ("color",) * 6, shape=(0, 1, 2, 3, 4), color=tuple(range(5, 11)),
    description="opaque rotated rectangle of bristle paint; colour blends head to tail", reference=(5, 6), softness=0.5,
)
