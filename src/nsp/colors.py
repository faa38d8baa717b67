"""Colours: names and ``#rrggbb`` (:func:`parse_color`, :func:`hex_color`), and CIE L*a*b* (sRGB
primaries, D65 white) divided by 100: L in [0, 1], a and b about [−1, 1]. Colour mode (paper §3.5)
recolours in L*a*b* and the style measures compare colours in it: its distances follow perceived
differences, and L depends on luminance alone, so a map that keeps L keeps a painting's luminance."""
from __future__ import annotations

import re

import torch
from torch import Tensor

from nsp.errors import BadInput

_NAMED = {"black": (0.0, 0.0, 0.0), "white": (1.0, 1.0, 1.0)}


def parse_color(value: str | tuple | list) -> tuple[float, float, float]:
    """``black``, ``white``, ``#rrggbb`` or an RGB triple in [0, 1] -> (r, g, b) in [0, 1]."""
    if isinstance(value, (tuple, list)) and len(value) == 3:
        return tuple(float(v) for v in value)
    text = str(value).strip().lower()
    if text in _NAMED:
        return _NAMED[text]
    if re.fullmatch(r"#[0-9a-f]{6}", text):
        return tuple(int(text[i : i + 2], 16) / 255 for i in (1, 3, 5))
    raise BadInput(f"background={value} is not a colour; expected black, white or #rrggbb")


def hex_color(rgb) -> str:
    """(r, g, b) in [0, 1] -> ``#rrggbb``."""
    return "#" + "".join(f"{round(float(c) * 255):02x}" for c in rgb)


SRGB_TO_XYZ = torch.tensor([  # linear sRGB -> CIE XYZ, D65
    [0.4124564, 0.3575761, 0.1804375],
    [0.2126729, 0.7151522, 0.0721750],
    [0.0193339, 0.1191920, 0.9503041],
])
WHITE = SRGB_TO_XYZ.sum(1)  # XYZ of RGB (1, 1, 1)
DELTA = 6 / 29  # where the cube root of L*a*b* turns linear


def rgb_to_lab(rgb: Tensor, dim: int = -1) -> Tensor:
    """sRGB in [0, 1] -> L*a*b* / 100, the three channels along ``dim`` (any shape)."""
    rgb = rgb.movedim(dim, -1)
    linear = torch.where(rgb <= 0.04045, rgb / 12.92, ((rgb.clamp(min=0) + 0.055) / 1.055) ** 2.4)
    xyz = linear @ SRGB_TO_XYZ.to(rgb).T / WHITE.to(rgb)
    f = torch.where(xyz > DELTA**3, xyz.clamp(min=DELTA**3) ** (1 / 3), xyz / (3 * DELTA**2) + 4 / 29)
    fx, fy, fz = f.unbind(-1)
    lab = torch.stack([1.16 * fy - 0.16, 5 * (fx - fy), 2 * (fy - fz)], -1)
    return lab.movedim(-1, dim)


def lab_to_rgb(lab: Tensor, dim: int = -1) -> Tensor:
    """L*a*b* / 100 -> sRGB, the inverse of :func:`rgb_to_lab`; out-of-gamut colours come back outside [0, 1]."""
    lab = lab.movedim(dim, -1)
    fy = (lab[..., 0] + 0.16) / 1.16
    f = torch.stack([fy + lab[..., 1] / 5, fy, fy - lab[..., 2] / 2], -1)
    xyz = torch.where(f > DELTA, f**3, 3 * DELTA**2 * (f - 4 / 29)) * WHITE.to(lab)
    linear = xyz @ torch.linalg.inv(SRGB_TO_XYZ).to(lab).T
    rgb = torch.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear.clamp(min=0.0031308) ** (1 / 2.4) - 0.055)
    return rgb.movedim(-1, dim)
