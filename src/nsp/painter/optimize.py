"""The one stroke-optimization loop (paper §3.3): gradient steps on stroke parameters kept in [0, 1],
and the paper's optimizer for it."""
from __future__ import annotations

from typing import Callable, Iterable, Iterator, Protocol, Sequence

import torch
from torch import Tensor

from nsp.engine.device import to_device


class Optimizer(Protocol):
    """What the loop needs of an optimizer: :class:`RMSprop`, or any ``torch.optim`` one."""

    def zero_grad(self) -> None: ...

    def step(self) -> None: ...


class RMSprop:
    """``torch.optim.RMSprop``'s update (no momentum, not centred), written out because the first use
    of any ``torch.optim`` optimizer imports ``torch._dynamo``, seconds of a painting. v ← α·v + (1 − α)·g²,
    p ← p − lr_t·g / (√v + ε); ``corrected``: lr_t = lr·√(1 − α^t) at step t, so the first steps, while v
    is still mostly its zero start, are not up to 1/√(1 − α) = 10× lr."""

    def __init__(self, params: Iterable[Tensor], lr: float = 0.01, alpha: float = 0.99, eps: float = 1e-8,
                 corrected: bool = False):
        self.params = list(params)
        self.lr, self.alpha, self.eps, self.corrected = lr, alpha, eps, corrected
        self.square = [torch.zeros_like(p) for p in self.params]
        self.steps = 0

    def zero_grad(self) -> None:
        for p in self.params:
            p.grad = None

    @torch.no_grad()
    def step(self) -> None:
        self.steps += 1
        lr = self.lr * ((1 - self.alpha**self.steps) ** 0.5 if self.corrected else 1.0)
        for p, v in zip(self.params, self.square):
            if p.grad is not None:
                v.mul_(self.alpha).addcmul_(p.grad, p.grad, value=1 - self.alpha)
                p.addcdiv_(p.grad, v.sqrt().add_(self.eps), value=-lr)


def bias_corrected(optimizer: Optimizer) -> Optimizer:
    """``optimizer`` with RMSprop's first steps bias-corrected, lr_t = lr·√(1 − α^t) (uncorrected, they
    scatter every stroke of a finished painting): this module's :class:`RMSprop` by its flag,
    ``torch.optim.RMSprop`` by a step pre-hook on its learning rates; any other optimizer as it is."""
    if isinstance(optimizer, RMSprop):
        optimizer.corrected = True
    elif isinstance(optimizer, torch.optim.RMSprop):
        rates, step = [group["lr"] for group in optimizer.param_groups], [0]

        def correct(opt: torch.optim.Optimizer, args: tuple, kwargs: dict) -> None:
            step[0] += 1
            for group, lr in zip(opt.param_groups, rates):
                group["lr"] = lr * (1 - group["alpha"] ** step[0]) ** 0.5

        optimizer.register_step_pre_hook(correct)
    return optimizer


def optimize_strokes(x: Tensor, optimizer: Optimizer, steps: int,
                     objective: Callable[[], tuple[Tensor, dict[str, Tensor]]],
                     frozen: Sequence[int] = ()) -> Iterator[tuple[Tensor, dict[str, Tensor]]]:
    """Take ``steps`` steps of ``optimizer`` on the strokes ``x`` (…, d), a leaf that requires grad,
    each clamped to [0, 1] after; parameters at the indices ``frozen`` (of the last axis) do not move.
    ``objective()`` renders the current strokes: (canvas, losses) with the weighted ``losses["total"]``.
    Yields, per step, the canvas the step was computed on and the losses, detached tensors on the
    strokes' device: nothing here waits for the device (reading a loss, ``float(value)``, does)."""
    keep = moving(x, frozen)
    for _ in range(steps):
        yield step_strokes(x, optimizer, objective, keep)


def moving(x: Tensor, frozen: Sequence[int]) -> Tensor | None:
    """(d,) 1 where a parameter of strokes x (…, d) moves, 0 at the indices ``frozen``; None: all move."""
    if not frozen:
        return None
    keep = torch.tensor([float(i not in frozen) for i in range(x.shape[-1])], dtype=x.dtype, device="cpu")
    return to_device(keep, x.device)


def step_strokes(x: Tensor, optimizer: Optimizer, objective: Callable[[], tuple[Tensor, dict[str, Tensor]]],
                 keep: Tensor | None = None) -> tuple[Tensor, dict[str, Tensor]]:
    """One step of :func:`optimize_strokes`, its gradient scaled by ``keep`` (d,) (:func:`moving`; None:
    all move): a product, not an index, so a step makes no tensor of host data (on a GPU, a copy)."""
    canvas, losses = objective()
    optimizer.zero_grad()
    losses["total"].backward()
    if keep is not None:
        x.grad.mul_(keep)
    optimizer.step()
    with torch.no_grad():
        x.clamp_(0, 1)
    return canvas.detach(), {name: value.detach() for name, value in losses.items()}
