"""Oil paint: an opaque rotated rectangle carrying a bristle texture, its colour blending from
(R0, G0, B0) at the head to (R2, G2, B2) at the tail."""
from __future__ import annotations

from dataclasses import dataclass, field

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.tape import rectangle, rectangle_extent
from nsp.brushes.texture import bristle_texture, load_texture
from nsp.brushes.geometry import box

_OPAQUE = 0.4  # texture values above this are fully covered with paint


@torch.compiler.disable  # ATen's grid_sample beats the compiled one; the texture cache stays in Python
def sample(texture: Tensor, u: Tensor, v: Tensor) -> Tensor:
    """Bilinear texture values (P, N) at (u, v) ∈ [0, 1]² (P, N) of a (1, 1, h, w) texture."""
    grid = torch.stack([2 * u - 1, 2 * v - 1], -1)[:, None]  # (P, 1, N, 2)
    return F.grid_sample(texture.expand(len(u), -1, -1, -1), grid, align_corners=True)[:, 0, 0]


@dataclass(frozen=True, eq=False)
class OilPaint(Brush):
    _cache: dict = field(default_factory=dict, repr=False)

    def texture(self, device, dtype, canvas_width: int | None = None) -> Tensor:
        """The bristle texture as (1, 1, h, w) on ``device``.

        For a canvas narrower than the texture it is area-downsampled to at most the canvas width,
        so small renders are not aliased (a mipmap level).
        """
        key = (str(device), dtype, canvas_width)
        if key not in self._cache:
            tex = load_texture(self.texture_path) if self.texture_path else bristle_texture()
            tex = tex[None, None].to(device=device, dtype=dtype)
            if canvas_width is not None and canvas_width < tex.shape[-1]:
                scale = max(canvas_width, 16) / tex.shape[-1]
                size = (max(4, round(tex.shape[-2] * scale)), max(16, round(tex.shape[-1] * scale)))
                tex = F.interpolate(tex, size=size, mode="area")
            self._cache[key] = tex
        return self._cache[key]

    def extent(self, x: Tensor, width: int, height: int) -> Tensor:
        return rectangle_extent(x, width, height)

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        return box(*rectangle(x, pix))

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        along, across, half_w, half_h = rectangle(x, pix)
        cov = coverage(box(along, across, half_w, half_h))
        u = along / (2 * half_w.clamp(min=0.5))[:, None] + 0.5  # 0 at the head, 1 at the tail
        v = across / (2 * half_h.clamp(min=0.5))[:, None] + 0.5
        value = sample(self.texture(x.device, x.dtype, pix.width), u, v)
        alpha = cov * (value / _OPAQUE).clamp(0, 1)
        c0, c2 = x[:, 5:8, None], x[:, 8:11, None]
        color = (c0 + (c2 - c0) * u.clamp(0, 1)[:, None]) * (0.7 + 0.3 * value[:, None])
        return color * (alpha > 0)[:, None], alpha


OILPAINT = OilPaint(
    name="oilpaint",
    params=("x", "y", "w", "h", "theta", "R0", "G0", "B0", "R2", "G2", "B2"),
    kinds=("x", "y", "size", "size", "angle") + ("color",) * 6,
    shape=(0, 1, 2, 3, 4),
    color=tuple(range(5, 11)),
    alpha=None,
    description="opaque rotated rectangle with a bristle texture; colour blends head to tail",
)
