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
GLAZING = ("watercolor", "markerpen")  # the pigments whose ``glaze`` can be chosen (Brush.glaze)


def get_brush(name: str, texture: str | None = None, params: list[str] | None = None, *, seed: int = 0,
              impasto: bool = True, glaze: float | None = None) -> Brush:
    """The brush called ``name``; ``texture``: a grayscale image path for ``oilpaint``; ``params``: the
    parameter names a stroke file lists, picking the variant that has exactly those; ``seed``: with each
    stroke's index, draws oil's stroke-to-stroke variation; ``impasto``: lights oil paint's relief; ``glaze``:
    how far watercolor's or the marker's paint multiplies what is under it (None: the brush's own)."""
    if name not in BRUSHES:
        raise BadInput(f"unknown brush '{name}', expected one of: {', '.join(BRUSHES)}")
    brush = next((b for b in VARIANTS if b.name == name and list(b.params) == params), BRUSHES[name])
    if texture is not None or not impasto:
        if name != "oilpaint":
            raise BadInput(f"brush.{'texture' if texture is not None else 'impasto'} applies to oilpaint only, not '{name}'")
        if texture is not None:
            load_texture(texture)  # a bad file fails here, before any work
        brush = dataclasses.replace(brush, texture_path=None if texture is None else str(texture), impasto=impasto, _cache={})
    if glaze is not None:
        if name not in GLAZING:
            raise BadInput(f"brush.glaze applies to {' and '.join(GLAZING)} only, not '{name}'")
        if isinstance(glaze, bool) or not isinstance(glaze, (int, float)) or not 0 <= glaze <= 1:
            raise BadInput(f"brush.glaze={glaze}: expected a number from 0 (paint covers what is under it) "
                           "to 1 (a glaze: overlaps multiply)")
        if glaze != brush.glaze:  # its own cache: a Detailed brush's plain and sized forms carry the glaze
            brush = dataclasses.replace(brush, glaze=float(glaze), _cache={})
    return dataclasses.replace(brush, seed=seed) if seed else brush
