"""Style transfer on strokes (paper §3.5): after the content painting, every stroke of the painting
is optimized further on the whole canvas with L = content loss + β_sty·L_style.

``mode="full"`` changes every parameter (colour and texture of the style), ``mode="color"`` only the
colour parameters (the paper's colour-only row); shape parameters then stay bit for bit.
"""
from __future__ import annotations

from typing import Callable, Sequence

import torch
from torch import Tensor
from torch.optim import Optimizer

from nsp.brushes import Brush
from nsp.engine import paint_canvas

MODES = ("full", "color")


def stylize(
    brush: Brush,
    strokes: Tensor,
    target: Tensor,
    content: Callable[[Tensor, Tensor], dict[str, Tensor]],
    style: Callable[[Tensor], Tensor],
    optimizer: Callable[[list[Tensor]], Optimizer],
    *,
    weight: float = 0.5,
    steps: int = 200,
    mode: str = "full",
    background: str = "white",
    softness: float = 0.5,
    callbacks: Sequence[Callable[[int, dict[str, float]], None]] = (),
) -> Tensor:
    """Optimize ``strokes`` (N, d) so the painting keeps ``target`` (3, H, W) and takes the style.

    The canvas is the soft vector engine at the target's size. ``content(canvas, target)`` returns
    the painter's terms with their weighted ``total``; ``style(canvas)`` the style loss.
    Returns the stylized strokes (N, d) in [0, 1]; each callback gets (step, losses).
    """
    if mode not in MODES:
        raise ValueError(f"style.mode={mode}: expected one of {', '.join(MODES)}")
    _, height, width = target.shape
    trainable = list(range(brush.d)) if mode == "full" else list(brush.color)
    x = strokes.detach().clone()
    free = x[:, trainable].clone().requires_grad_(True)  # only these move: the rest stays bit for bit
    opt = optimizer([free])
    for step in range(1, steps + 1):
        params = x.index_copy(1, torch.tensor(trainable), free)
        canvas = paint_canvas(brush, params, height, width, background, softness=softness)[None]
        losses = content(canvas, target[None])
        losses["style"] = style(canvas)
        losses["total"] = losses["total"] + weight * losses["style"]
        opt.zero_grad()
        losses["total"].backward()
        opt.step()
        with torch.no_grad():
            free.clamp_(0, 1)
        for callback in callbacks:
            callback(step, {name: float(value.detach()) for name, value in losses.items()})
    return x.index_copy(1, torch.tensor(trainable), free.detach())
