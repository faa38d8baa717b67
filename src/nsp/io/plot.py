"""``plot.svg``: a painting of K paints as a pen plotter or painting robot takes it, and as Inkscape,
vpype, WaterColorBot and RoboPaint read it: an Inkscape layer a paint (``inkscape:groupmode="layer"``,
labelled with its number and colour), in the order the paints are laid, each stroke a path along its
middle (:meth:`nsp.brushes.base.Brush.centreline`) in its paint, its width and its brush's caps (a
watercolor's in pieces of the width its discs have there, grouped under the stroke's opacity)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import parse_color
from nsp.files import atomic_path

INKSCAPE = "http://www.inkscape.org/namespaces/inkscape"


def layers(brush: Brush, p: np.ndarray, paints: list[str]) -> np.ndarray:
    """The layer (N,) of each stroke p (N, d): the paint (``#rrggbb``) nearest its colour, so a stroke whose
    colour is none of them (a file edited by hand) goes where it comes closest."""
    palette = np.array([parse_color(paint) for paint in paints])
    color = p[:, list(brush.color)].reshape(len(p), -1, 3).mean(1)
    return ((color[:, None] - palette[None]) ** 2).sum(-1).argmin(1)


def write_plot(path: str | Path, brush: Brush, strokes: Tensor, paints: list[str], height: int, width: int) -> None:
    """Strokes (N, d), each one of ``paints`` (``#rrggbb``, layer by layer) and in layer order, as
    ``plot.svg`` on a ``height``×``width`` canvas (no background: the paper is the machine's), a stroke
    in its :func:`layers` layer."""
    p = strokes.detach().cpu().double().numpy()
    layer = layers(brush, p, paints)
    opacity = np.ones(len(p)) if brush.alpha is None else p[:, brush.alpha]
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="{INKSCAPE}" width="{width}" height="{height}" '
           f'viewBox="-0.5 -0.5 {width} {height}">']
    for index, paint in enumerate(paints):
        svg.append(f'<g inkscape:groupmode="layer" inkscape:label="{index + 1} {paint}" id="layer{index + 1}">')
        for stroke in np.flatnonzero(layer == index):
            pieces = [f'<path d="{line}" fill="none" stroke="{paint}" stroke-width="{pen:.2f}" stroke-linecap="{cap}"'
                      for line, pen, cap in brush.centreline(p[stroke], height, width)]
            if len(pieces) == 1:
                svg.append(f'{pieces[0]} stroke-opacity="{opacity[stroke]:.3f}"/>')
            else:  # its pieces' overlaps painted once: the stroke's opacity on the group
                svg += [f'<g opacity="{opacity[stroke]:.3f}">', *(piece + "/>" for piece in pieces), "</g>"]
        svg.append("</g>")
    svg.append("</svg>")
    with atomic_path(path) as temporary:
        temporary.write_text("\n".join(svg))
