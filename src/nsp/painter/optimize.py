"""The one stroke-optimization loop (paper §3.3): gradient steps on stroke parameters kept in [0, 1]."""
from __future__ import annotations

from typing import Callable, Iterator, Sequence

import torch
from torch import Tensor
from torch.optim import Optimizer


def optimize_strokes(
    x: Tensor,
    optimizer: Optimizer,
    steps: int,
    objective: Callable[[], tuple[Tensor, dict[str, Tensor]]],
    frozen: Sequence[int] = (),
) -> Iterator[tuple[Tensor, dict[str, float]]]:
    """Take ``steps`` steps of ``optimizer`` on the strokes ``x`` (…, d), a leaf that requires grad.

    ``objective()`` renders the current strokes: (canvas, losses) with the weighted ``losses["total"]``.
    Parameters at the indices ``frozen`` (of the last axis) do not move; after each step every
    parameter is clamped to [0, 1]. Yields, per step, the canvas the step was computed on
    (detached) and the losses as numbers.
    """
    for _ in range(steps):
        canvas, losses = objective()
        optimizer.zero_grad()
        losses["total"].backward()
        if frozen:
            x.grad[..., list(frozen)] = 0
        optimizer.step()
        with torch.no_grad():
            x.clamp_(0, 1)
        yield canvas.detach(), {name: float(value.detach()) for name, value in losses.items()}
