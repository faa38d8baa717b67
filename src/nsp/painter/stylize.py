"""Style transfer on strokes (paper §3.5), after the content painting.

Both modes first recolour the painting toward the style image with one map shared by every stroke
and by the canvas colour (:class:`nsp.style.Recoloring`), so colours that were alike stay alike: a
pixel where a translucent stroke shows the canvas is recoloured as one where an opaque stroke shows
a colour alike. The map is fitted to the style's colours as far as the luminance structure
and coherence allow (:func:`recolor`): the painting keeps at least 1 − β_sty/5 of its luminance
SSIM to the photo, and colours alike in it stay within :data:`COHERENT` of each other.

- ``mode="color"`` stops there: only colour parameters change, shape parameters stay bit for bit,
  and the lightness keeps the photo's structure.
- ``mode="full"`` then optimizes every parameter on the whole canvas with
  L = content loss + β_sty·L_style, for the style's texture. The content loss compares the canvas
  with the photo recoloured by the same map, so it keeps the picture, not its old colours. Last, a
  shared map puts the chroma back on the style's: the style loss of random filters barely sees flat
  colour, so the strokes' hues drift while they take the texture.

β_sty (``weight``) is the one content/style balance of both modes.
"""
from __future__ import annotations

from typing import Callable, Sequence

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import hex_color, parse_color
from nsp.config import MODES
from nsp.engine import paint_canvas
from nsp.painter.optimize import Optimizer, RMSprop, optimize_strokes
from nsp.style import Recoloring, StyleLoss
from nsp.style.measures import SAMPLES, alike_pairs, color_distance, luminance_ssim, parted
from nsp.style.refine import refine_colors

STRUCTURE = 0.2  # the share of luminance SSIM the recolouring may give up, per unit of β_sty
STEPS = 10  # the shares of the refined map tried, back toward the start: 1, 1 − 1/STEPS, …, 1/STEPS
COHERENT = 0.048  # the most colours alike in the painting may part on average (RGB): nsp.style.measures.coherence


def stylize(
    brush: Brush,
    strokes: Tensor,
    target: Tensor,
    style: Tensor,
    content: Callable[[Tensor, Tensor], dict[str, Tensor]],
    optimizer: Callable[[list[Tensor]], Optimizer],
    *,
    weight: float,
    steps: int,
    loss: StyleLoss | None = None,
    mode: str = "full",
    background: str = "white",
    softness: float | None = None,
    callbacks: Sequence[Callable[[int, dict[str, float]], None]] = (),
) -> tuple[Tensor, str]:
    """Restyle ``strokes`` (N, d), a painting of ``target`` (3, H, W), in the style of the image
    ``style`` (3, h, w), all RGB in [0, 1].

    The canvas is the vector engine at the target's size. Full mode's steps need ``loss``, the
    style loss against ``style`` (``loss(canvas)``); ``content(canvas, target)`` returns the
    painter's terms with their weighted ``total``. Colour mode uses neither, nor ``optimizer``: it
    builds no feature network. ``weight`` is β_sty: how far the lightness follows the style's, and
    in full mode the style loss's weight in the ``steps`` optimizer steps, on soft edges
    ``softness`` px wide (None: the brush's own).
    Returns the stylized strokes (N, d) in [0, 1] and the canvas colour ``background`` recoloured
    by the same map (``#rrggbb``); each callback gets (step, losses) after each step.
    """
    if mode not in MODES:
        raise ValueError(f"style.mode={mode}: expected one of {', '.join(MODES)}")
    if mode == "full" and loss is None:
        raise ValueError("style.mode=full: the style steps need the style loss (loss=StyleLoss(style[None], …))")
    if weight < 0:
        raise ValueError(f"style.weight={weight}: expected β_sty ≥ 0")
    _, height, width = target.shape
    with torch.no_grad():
        plain = paint_canvas(brush, strokes, height, width, background)
    recoloring = recolor(brush, strokes, plain, target, style, weight, background)
    x = recoloring.strokes(brush, strokes)
    if mode == "color":
        if weight == 0:
            return x, canvas_color(recoloring, background)
        x, canvas = refine_colors(brush, x, recoloring(torch.tensor(parse_color(background))), plain, target, style,
                                  floor(plain, target, weight), COHERENT)
        return x, hex_color(canvas)
    background = canvas_color(recoloring, background)
    target = recoloring(target, dim=0)[None]  # the photo in the style's colours
    x.requires_grad_(True)
    opt = optimizer([x])
    if isinstance(opt, RMSprop):  # on a finished painting, uncorrected first steps would scatter every stroke
        opt.corrected = True
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
    """The canvas colour ``background`` (as :func:`~nsp.engine.parse_color` reads it) through
    ``recoloring``, as ``#rrggbb``: where translucent strokes show the canvas, it is one of the
    painting's colours."""
    return hex_color(recoloring(torch.tensor(parse_color(background))))


def floor(plain: Tensor, target: Tensor, weight: float) -> float:
    """The least luminance SSIM to ``target`` a restyled painting keeps: (1 − STRUCTURE·``weight``)
    × the ``plain`` painting's (both (3, H, W))."""
    return (1 - STRUCTURE * weight) * luminance_ssim(plain, target)


def recolor(brush: Brush, strokes: Tensor, painting: Tensor, target: Tensor, style: Tensor, weight: float,
            background: str = "white") -> Recoloring:
    """The shared recolouring of the painting ``strokes`` (N, d) of ``target`` (3, H, W) toward
    ``style`` (3, h, w), ``painting`` (3, H, W) their painting on ``background``, under a floor of
    (1 − STRUCTURE·``weight``) × its luminance SSIM to ``target`` and a bound of :data:`COHERENT` on
    how far alike colours part.

    From the Gaussian start (:meth:`Recoloring.fit`), two ends: the start refined on the painting's
    pixels (:meth:`Recoloring.refine`), and the style's tones matched
    (:meth:`Recoloring.matched_tones`). Each is checked on the painted strokes, where translucent
    strokes blend recoloured colours, and where a bound fails it is taken back toward the start,
    1/STEPS of the way at a time. Of the two, the one whose painting is nearer the style's colours
    wins. ``weight`` (β_sty ≥ 0) 0 keeps the lightness: the start alone.
    """
    _, height, width = target.shape
    start = Recoloring.fit(painting, style)
    if weight == 0:
        return start
    least = floor(painting, target, weight)
    ends = start.refine(painting, target, style, least, COHERENT), start.matched_tones(painting, style)
    alike = alike_pairs(painting.flatten(1).T.float(), SAMPLES, torch.Generator().manual_seed(1))  # as coherence pairs
    kept = []  # (colour distance, recolouring) within both bounds
    with torch.no_grad():
        for end in ends:
            for share in range(STEPS, 0, -1):
                recoloring = start.toward(end, share / STEPS)
                canvas = paint_canvas(brush, recoloring.strokes(brush, strokes), height, width,
                                      canvas_color(recoloring, background))
                apart = parted(canvas, *alike)  # NaN where no two colours are alike: nothing to part
                if luminance_ssim(canvas, target) >= least and not apart > COHERENT:
                    kept.append((color_distance(canvas, style, seed=1), recoloring))
                    break
    return min(kept, key=lambda scored: scored[0])[1] if kept else start
