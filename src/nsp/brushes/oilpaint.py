"""Oil paint: an opaque rotated rectangle carrying a bristle texture, its colour blending from
(R0, G0, B0) at the head to (R2, G2, B2) at the tail."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.svg import UNIT, hex_color, png_data_uri, rectangle_frame
from nsp.brushes.tape import rectangle, rectangle_extent
from nsp.brushes.texture import bristle_texture, load_texture
from nsp.brushes.geometry import box

_OPAQUE = 0.4  # texture values above this are fully covered with paint


def sample(texture: Tensor, u: Tensor, v: Tensor) -> Tensor:
    """Bilinear texture values (P, N) at (u, v) ∈ [0, 1]² (P, N) of a (1, 1, h, w) texture."""
    return _grid_sample(texture, u, v)


def _grid_sample(texture: Tensor, u: Tensor, v: Tensor) -> Tensor:
    grid = torch.stack([2 * u - 1, 2 * v - 1], -1)[:, None]  # (P, 1, N, 2)
    return F.grid_sample(texture.expand(u.shape[0], -1, -1, -1), grid, align_corners=True)[:, 0, 0]


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

    def extent(self, x: Tensor, height: int, width: int) -> Tensor:
        return rectangle_extent(x, height, width)

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

    def svg_defs(self) -> list[str]:
        """The texture, as an alpha mask and a shading overlay in the unit square of a stroke."""
        texture = self.texture("cpu", torch.float32)[0, 0].numpy()
        alpha = np.clip(texture / _OPAQUE, 0, 1)
        shade = 0.3 * (1 - texture)  # black at this opacity multiplies the colour by 0.7 + 0.3·texture
        unit = UNIT + ' preserveAspectRatio="none"'
        return [
            f'<mask id="oil-mask" maskUnits="userSpaceOnUse" {UNIT}><image {unit} href="{png_data_uri(alpha)}"/></mask>',
            f'<image id="oil-shade" {unit} href="{png_data_uri(np.zeros_like(shade), shade)}"/>',
        ]

    def svg(self, index: int, p: np.ndarray, height: int, width: int) -> tuple[str, str]:
        gradient = (
            f'<linearGradient id="g{index}" gradientUnits="userSpaceOnUse" x1="-0.5" y1="0" x2="0.5" y2="0">'
            f'<stop offset="0" stop-color="{hex_color(p[5:8])}"/><stop offset="1" stop-color="{hex_color(p[8:11])}"/>'
            "</linearGradient>"
        )
        body = f'<rect {UNIT} fill="url(#g{index})"/><use href="#oil-shade"/>'
        return gradient, f'<g {rectangle_frame(p, height, width)} mask="url(#oil-mask)">{body}</g>'

    def from_reference(self, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, width: int) -> tuple[Brush, np.ndarray]:
        sizes = (1 + ctt[:, 2:4] * width) / width  # extents 1 + w·W px -> fraction of W; its alpha is unused
        return self, np.clip(np.concatenate([ctt[:, :2], sizes, ctt[:, 4:5], color], 1), 0, 1)


OILPAINT = OilPaint(
    name="oilpaint",
    params=("x", "y", "w", "h", "theta", "R0", "G0", "B0", "R2", "G2", "B2"),
    kinds=("x", "y", "size", "size", "angle") + ("color",) * 6,
    shape=(0, 1, 2, 3, 4),
    color=tuple(range(5, 11)),
    alpha=None,
    description="opaque rotated rectangle with a bristle texture; colour blends head to tail",
    reference=(5, 6),
    softness=0.5,
)
