"""Style transfer on strokes (paper §3.5), after the content painting.

Both modes first recolour the painting toward the style image with one map shared by every stroke
and by the canvas colour (:mod:`nsp.style.recolor`), so colours that were alike stay alike (where a
translucent stroke shows the canvas too). β_sty (``weight``) is the content/style balance of both.

- ``mode="color"`` is :func:`nsp.style.recolor.recolor`: the shared map, then each stroke's colours
  on their own, within the same bounds; shape parameters stay bit for bit.
- ``mode="full"`` then optimizes every parameter on the whole canvas with L = content loss +
  β_sty·L_style, for the style's texture. The content loss compares the canvas with the photo
  recoloured by the same map, so it keeps the picture, not its old colours. Last, a shared map puts
  the chroma back on the style's: the style loss of random filters barely sees flat colour, so the
  strokes' hues drift while they take the texture.
"""
from __future__ import annotations

from typing import Callable, Sequence

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import hex_color, parse_color
from nsp.config import MODES
from nsp.engine import paint_canvas
from nsp.painter.optimize import Optimizer, bias_corrected, optimize_strokes
from nsp.style import Recoloring, StyleLoss
from nsp.style.recolor import ColorSettings, recolor, shared_map


def stylize(brush: Brush, strokes: Tensor, target: Tensor, style: Tensor,
            content: Callable[[Tensor, Tensor], dict[str, Tensor]], optimizer: Callable[[list[Tensor]], Optimizer], *,
            weight: float, steps: int, loss: StyleLoss | None = None, mode: str = "full", background: str = "white",
            softness: float | None = None, seed: int = 0, color: ColorSettings = ColorSettings(),
            callbacks: Sequence[Callable[[int, dict[str, Tensor]], None]] = (),
            tick: Callable[[], None] | None = None) -> tuple[Tensor, str]:
    """Restyle ``strokes`` (N, d), a painting of ``target`` (3, H, W), in the style of the image
    ``style`` (3, h, w), all RGB in [0, 1], on the vector engine at the target's size. Returns the
    stylized strokes (N, d) in [0, 1] and the canvas colour ``background`` recoloured by the same
    map (``#rrggbb``).

    Full mode's steps need ``loss``, the style loss against ``style`` (``loss(canvas)``);
    ``content(canvas, target)`` returns the painter's terms with their weighted ``total``. Colour
    mode uses neither, nor ``optimizer``: it builds no feature network. ``weight`` is β_sty: how far
    the lightness follows the style's, and in full mode the style loss's weight in the ``steps``
    optimizer steps, on soft edges ``softness`` px wide (None: the brush's own); each callback gets
    (step, losses) after each. ``seed`` and ``color`` seed and set the recolouring; colour mode calls
    ``tick`` after each of its fits' steps.
    """
    if mode not in MODES:
        raise ValueError(f"style.mode={mode}: expected one of {', '.join(MODES)}")
    if mode == "full" and loss is None:
        raise ValueError("style.mode=full: the style steps need the style loss (loss=StyleLoss(style[None], …))")
    if weight < 0:
        raise ValueError(f"style.weight={weight}: expected β_sty ≥ 0")
    if mode == "color":
        return recolor(brush, strokes, target, style, weight, background, seed, color, tick)
    _, height, width = target.shape
    with torch.no_grad():
        plain = paint_canvas(brush, strokes, height, width, background)
    recoloring = shared_map(brush, strokes, plain, target, style, weight, background, seed, color)
    x = recoloring.strokes(brush, strokes)
    background = canvas_color(recoloring, background)
    target = recoloring(target, dim=0)[None]  # the photo in the style's colours
    x.requires_grad_(True)
    opt = bias_corrected(optimizer([x]))  # on a finished painting
    edge = brush.softness if softness is None else softness

    def objective() -> tuple[Tensor, dict[str, Tensor]]:
        canvas = paint_canvas(brush, x, height, width, background, softness=edge)[None]
        losses = content(canvas, target)
        losses["style"] = loss(canvas)
        losses["total"] = losses["total"] + weight * losses["style"]
        return canvas, losses

    for step, (_, losses) in enumerate(optimize_strokes(x, opt, steps, objective), start=1):
        for callback in callbacks:
            callback(step, losses)
    with torch.no_grad():
        painting = paint_canvas(brush, x, height, width, background)
    chroma = Recoloring.fit(painting, style)  # the lightness as optimized
    return chroma.strokes(brush, x), canvas_color(chroma, background)


def canvas_color(recoloring: Recoloring, background: str) -> str:
    """The canvas colour ``background`` through ``recoloring``, as ``#rrggbb``: where translucent strokes
    show the canvas, it is one of the painting's colours."""
    return hex_color(recoloring(torch.tensor(parse_color(background))))
