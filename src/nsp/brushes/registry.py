"""Every brush by name. Adding a brush: one module in this package and one entry in ``BRUSHES``;
its ``brush=`` config is generated from here (``nsp.config``)."""
from __future__ import annotations

import dataclasses

from nsp.brushes.base import Brush
from nsp.brushes.markerpen import MARKERPEN
from nsp.brushes.oilpaint import OILPAINT
from nsp.brushes.tape import TAPE, TRANSLUCENT_TAPE
from nsp.brushes.texture import load_texture
from nsp.brushes.watercolor import WATERCOLOR
from nsp.errors import BadInput

BRUSHES: dict[str, Brush] = {b.name: b for b in (OILPAINT, WATERCOLOR, MARKERPEN, TAPE)}
VARIANTS = (TRANSLUCENT_TAPE,)  # brushes of the same name with other parameters, met in stroke files


def get_brush(name: str, texture: str | None = None, params: list[str] | None = None, *, seed: int = 0,
              impasto: bool = True) -> Brush:
    """The brush called ``name``; ``texture``: a grayscale image path for ``oilpaint``; ``params``: the
    parameter names a stroke file lists, picking the variant that has exactly those; ``seed``: with each
    stroke's index, draws oil's stroke-to-stroke variation; ``impasto``: lights oil paint's relief."""
    if name not in BRUSHES:
        raise BadInput(f"unknown brush '{name}', expected one of: {', '.join(BRUSHES)}")
    brush = next((b for b in VARIANTS if b.name == name and list(b.params) == params), BRUSHES[name])
    if texture is not None or not impasto:
        if name != "oilpaint":
            raise BadInput(f"brush.{'texture' if texture is not None else 'impasto'} applies to oilpaint only, not '{name}'")
        if texture is not None:
            load_texture(texture)  # a bad file fails here, before any work
        brush = dataclasses.replace(brush, texture_path=None if texture is None else str(texture), impasto=impasto, _cache={})
    return dataclasses.replace(brush, seed=seed) if seed else brush
