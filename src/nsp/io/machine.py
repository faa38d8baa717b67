"""Machine files: a painting of K paints as a pen plotter's HPGL or a painting robot's G-code, written by
vpype (and vpype-gcode) from one layer a paint, in the order the paints are laid. Each stroke is its
middle line (:meth:`nsp.brushes.base.Brush.centreline`) drawn in as many parallel passes of the pen as
cover its width, the painting fitted to the page within its margin; a stroke that later paint hides
entirely is left out (as vpype-occult leaves out lines hidden by shapes, here from the painting itself);
G-code pauses for a refill every N strokes or every so much line (``refill``)."""
from __future__ import annotations

import math
import re
import shlex
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.config import PlotConfig
from nsp.engine import paint_canvas
from nsp.errors import BadInput
from nsp.files import atomic_path
from nsp.io.plot import layers

MACHINE = (".hpgl", ".gcode")
CHECK_SIDE = 512  # the long side of the canvas a stroke's visibility is judged on
SHOWN = 1 / 255  # the least a stroke must show of itself somewhere to be drawn
SAMPLES = 17  # points along a curved middle line
GCODE = {  # vpype-gcode's profile: millimetres, the pen lifted between lines, a pause at each layer for its paint
    "document_start": "; a painting by nsp\nG21\nG90\nG00 Z5\n",
    "layer_start": "; layer {layer_index1}: {vp_name}\nM0 ; load {vp_name}\n",
    "segment_first": "G00 X{x:.3f} Y{y:.3f}\nG01 Z0 F600\n",
    "segment": "G01 X{x:.3f} Y{y:.3f} F3000\n",
    "line_end": "G00 Z5\n",
    "document_end": "G00 Z5\nM2\n",
    "unit": "mm",
    "vertical_flip": True,
}


def visible(brush: Brush, strokes: Tensor, height: int, width: int) -> np.ndarray:
    """Which strokes (N, d) show anywhere in the painting (N,) bool, judged on a canvas of
    :data:`CHECK_SIDE` px: each stroke's paint times what the strokes over it let through (a glaze lets its
    share of what is under it through even where opaque) must reach :data:`SHOWN` somewhere."""
    scale = CHECK_SIDE / max(height, width)
    h, w = max(1, round(height * scale)), max(1, round(width * scale))
    images = []
    with torch.no_grad():
        paint_canvas(brush.plain(), strokes.detach().cpu(), h, w, images=images)
    through = np.ones((h, w))  # of each pixel, the share the strokes above it let through
    shown = np.zeros(len(images), dtype=bool)
    for index in reversed(range(len(images))):
        left, top, image = images[index]
        alpha = image[..., 3].double().numpy()
        if alpha.size == 0:
            continue
        region = through[top : top + alpha.shape[0], left : left + alpha.shape[1]]
        shown[index] = (alpha * region).max() >= SHOWN
        region *= 1 - alpha * (1 - brush.glaze)
    return shown


def passes(brush: Brush, stroke: np.ndarray, height: int, width: int, scale: float, pen: float) -> list[np.ndarray]:
    """The lines (complex points, page units) a pen ``pen`` wide draws stroke ``stroke`` (d,) with, on a
    painting of height×width px drawn ``scale`` page units a pixel: each piece of its middle line, offset to
    either side in as many passes as cover its width there."""
    import shapely
    from svgelements import Path as SvgPath

    out = []
    for line, thickness, _ in brush.centreline(stroke, height, width):
        points = np.array(SvgPath(line).npoint(np.linspace(0, 1, SAMPLES if "Q" in line else 2))) * scale
        middle = shapely.LineString(points)
        count = max(1, math.ceil(thickness * scale / pen))
        step = thickness * scale / count
        for k in range(count):
            offset = (k - (count - 1) / 2) * step
            part = middle if abs(offset) < 1e-9 or middle.length == 0 else middle.offset_curve(offset)
            for piece in getattr(part, "geoms", [part]):
                xy = np.asarray(piece.coords)
                if len(xy) >= 2:
                    out.append(xy[:, 0] + 1j * xy[:, 1])
    return out


def lengths(value: str, key: str):
    """A vpype length (``2m``, ``0.5mm``, ``20`` without a unit is a count) in its units, or :class:`BadInput`."""
    import vpype as vp

    try:
        return vp.convert_length(value)
    except (ValueError, TypeError):
        raise BadInput(f"{key}={value}: expected a length with its unit (0.5mm, 2cm, 1in)") from None


def document(brush: Brush, strokes: Tensor, paints: list[str], height: int, width: int, plot: PlotConfig):
    """The vpype document of the painting: a layer a paint in its order (split at refills), the
    painting fitted within the page's margin, its lines :func:`passes` of the strokes :func:`visible`."""
    import vpype as vp

    try:
        page = vp.convert_page_size(plot.page)
    except (ValueError, TypeError):
        raise BadInput(f"plot.page={plot.page}: expected a page format ({', '.join(sorted(vp.PAGE_SIZES))}) "
                       "or WxH with a unit (30x40cm)") from None
    if (page[0] > page[1]) != (width > height):
        page = page[::-1]  # the page turned as the painting is
    margin, pen = lengths(plot.margin, "plot.margin"), lengths(plot.pen, "plot.pen")
    if pen <= 0 or 2 * margin >= min(page):
        raise BadInput(f"plot.pen={plot.pen}, plot.margin={plot.margin}: expected a pen wider than 0 and margins "
                       f"that leave some of the {plot.page} page")
    refill = _refill(plot.refill)
    scale = min((page[0] - 2 * margin) / width, (page[1] - 2 * margin) / height)
    shift = complex((page[0] - width * scale) / 2, (page[1] - height * scale) / 2)
    p = strokes.detach().cpu().double().numpy()
    layer = layers(brush, p, paints)
    shown = visible(brush, strokes, height, width)
    doc = vp.Document(page_size=page)
    for index, paint in enumerate(paints):
        chunk, drawn, part = [], 0.0, 0
        for stroke in np.flatnonzero((layer == index) & shown):
            if chunk and refill is not None and (drawn >= refill[1] if refill[0] == "length" else len(chunk) >= refill[1]):
                _add(doc, chunk, index, paint, part, pen)
                chunk, drawn, part = [], 0.0, part + 1
            lines = [line + shift for line in passes(brush, p[stroke], height, width, scale, pen)]
            chunk.append(lines)
            drawn += sum(float(np.abs(np.diff(line)).sum()) for line in lines)
        _add(doc, chunk, index, paint, part, pen)
    return doc


def _refill(value: str | None) -> tuple[str, float] | None:
    """``plot.refill``: None, ("count", N) or ("length", page units)."""
    if value is None:
        return None
    text = str(value).strip()
    if re.fullmatch(r"[0-9]+", text):
        if int(text) < 1:
            raise BadInput(f"plot.refill={value}: expected a number of strokes from 1, or a length (2m)")
        return "count", int(text)
    length = lengths(text, "plot.refill")
    if length <= 0:
        raise BadInput(f"plot.refill={value}: expected a number of strokes from 1, or a length (2m)")
    return "length", length


def _add(doc, chunk: list[list[np.ndarray]], index: int, paint: str, part: int, pen: float) -> None:
    """One layer of ``doc``: the strokes ``chunk`` in paint ``paint`` (number index + 1), its refill ``part``."""
    import vpype as vp

    if not chunk:
        return
    lines = vp.LineCollection([line for lines in chunk for line in lines])
    layer = len(doc.layers) + 1
    doc.add(lines, layer)
    name = f"{index + 1} {paint}" + (f" refill {part}" if part else "")
    doc.layers[layer].set_property(vp.METADATA_FIELD_NAME, name)
    doc.layers[layer].set_property(vp.METADATA_FIELD_COLOR, vp.Color(paint))
    doc.layers[layer].set_property(vp.METADATA_FIELD_PEN_WIDTH, pen)


def write_machine(path: str | Path, brush: Brush, strokes: Tensor, paints: list[str], height: int, width: int,
                  plot: PlotConfig) -> None:
    """HPGL or G-code (by ``path``'s extension) of strokes (N, d) laid in ``paints``, by vpype; the
    file appears whole or not at all."""
    import vpype as vp

    doc = document(brush, strokes, paints, height, width, plot)
    suffix = Path(path).suffix.lower()
    if suffix == ".hpgl" and plot.refill is not None:
        raise BadInput(f"plot.refill={plot.refill} applies to G-code (out=….gcode); an HPGL plotter's pens hold their ink")
    with atomic_path(path) as temporary, open(temporary, "w") as output:
        if suffix == ".hpgl":
            try:
                vp.write_hpgl(output, doc, page_size=plot.page, landscape=width > height, center=False,
                              device=plot.device, velocity=None, quiet=True)
            except (ValueError, KeyError) as error:
                raise BadInput(f"plot.device={plot.device}, plot.page={plot.page}: vpype has no such HPGL set-up "
                               f"({str(error).splitlines()[0][:100]})") from None
        else:
            import vpype_cli

            output.close()  # gwrite opens it itself
            vp.config_manager.config.setdefault("gwrite", {})["nsp"] = GCODE
            vpype_cli.execute(f"gwrite --profile nsp {shlex.quote(str(temporary))}", document=doc)
