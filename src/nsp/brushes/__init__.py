"""The four brushes of the paper (§3.1, appendix tables). Adding a brush: one module here and one line below."""
from __future__ import annotations

import dataclasses

from nsp.brushes.base import Brush, Pixels
from nsp.brushes.markerpen import MARKERPEN
from nsp.brushes.oilpaint import OILPAINT
from nsp.brushes.tape import TAPE
from nsp.brushes.texture import load_texture
from nsp.brushes.watercolor import WATERCOLOR

BRUSHES: dict[str, Brush] = {b.name: b for b in (OILPAINT, WATERCOLOR, MARKERPEN, TAPE)}


def get_brush(name: str, texture: str | None = None) -> Brush:
    """The brush called ``name``; ``texture`` is a grayscale image path for ``oilpaint``."""
    if name not in BRUSHES:
        raise ValueError(f"unknown brush '{name}', expected one of: {', '.join(BRUSHES)}")
    brush = BRUSHES[name]
    if texture is not None:
        if name != "oilpaint":
            raise ValueError(f"brush.texture applies to oilpaint only, not '{name}'")
        load_texture(texture)  # a bad file fails here, before any work
        brush = dataclasses.replace(brush, texture_path=str(texture), _cache={})
    return brush


__all__ = ["BRUSHES", "Brush", "Pixels", "get_brush"]
