"""A level's optimizer steps (paper §3.3, §3.6), two ways behind one interface: ``aim(k, least)``,
then each call one step of the first k strokes of the blocks with at least ``least``.

:class:`FreeSteps` take those strokes alone, a shape that changes with every stroke added: the
least work, the CPU's way. :class:`FixedSteps` take the whole level at every step (the strokes not
yet shown hidden: no alpha, so no gradient; the blocks done weighted 0: their canvas is their goal,
so no gradient; the losses scaled back to means over the blocks that move): the same gradients, so
the same strokes to float rounding (``tests/test_steps.py``), every stroke of the level shaded a step,
and one shape a level, so that on a GPU the step is captured once as a CUDA graph and replayed: one
launch for the hundreds of small kernels of a step (blocks of at most 64 px), where eager PyTorch
launches each from Python.
"""
from __future__ import annotations

import logging
from typing import Callable, Sequence

import torch
from torch import Tensor

from nsp.engine.device import to_device
from nsp.painter.optimize import Optimizer, RMSprop, step_strokes
from nsp.painter.palette import Palette

log = logging.getLogger(__name__)
WARMUP = 2  # eager steps before a capture, on a side stream: cuBLAS and autograd initialise lazily


class LevelSteps:
    """The steps of one level's strokes x (B, K, d), a leaf.

    Args:
        optimizer: x's optimizer; ``keep`` (d,) which parameters move (:func:`~nsp.painter.optimize.moving`).
        blend: ``blend(x, shown, under, goal, weights) -> (B, 3, s, s)``, the strokes composited.
        loss: ``loss(canvas, goal) -> {"total": …, …}``, 0-dim means over the blocks.
        under, goal, weights: (B, 3, s, s), (B, 3, s, s), (B, 1, s, s): each block's background, aim, weights.
        exists: (B, K) bool on the host, the strokes each block has.
        canvas: (B, 3, s, s), each moving block's canvas as the last step found it, written in place.
        palette: keeps the strokes' colours near the target's after each step, or None.
    """

    def __init__(self, x: Tensor, optimizer: Optimizer, keep: Tensor | None,
                 blend: Callable[..., Tensor], loss: Callable[[Tensor, Tensor], dict[str, Tensor]],
                 under: Tensor, goal: Tensor, weights: Tensor, exists: Tensor, canvas: Tensor,
                 palette: Palette | None):
        self.x, self.optimizer, self.keep, self.blend, self.loss = x, optimizer, keep, blend, loss
        self.under, self.goal, self.weights, self.canvas, self.palette = under, goal, weights, canvas, palette
        self.exists = exists


class FreeSteps(LevelSteps):
    """Each step the first k strokes of the moving blocks alone. ``taking``: each j's blocks with more
    than j strokes, on the device (one copy a level)."""

    def __init__(self, *args, taking: Sequence[Tensor]):
        super().__init__(*args)
        self.taking, self.counts = taking, self.exists.sum(1).tolist()

    def aim(self, k: int, least: int) -> None:
        """The next steps move the first ``k`` strokes of the blocks with at least ``least``."""
        self.at, self.k = self.taking[least - 1], k
        live = [b for b, count in enumerate(self.counts) if count >= least]
        everyone = all(self.counts[b] >= k for b in live)
        self.shown = None if everyone else to_device(self.exists[live, :k], self.x.device)
        self.background, self.aimed, self.weight = self.under[self.at], self.goal[self.at], self.weights[self.at]

    def __call__(self) -> dict[str, Tensor]:
        """One step: its losses (0-dim, on the device, means over the moving blocks), ``canvas`` updated."""
        at, k = self.at, self.k
        canvas, losses = step_strokes(self.x, self.optimizer, self._objective, self.keep)
        self.canvas[at] = canvas
        if self.palette is not None:
            with torch.no_grad():
                strokes = self.x[at, :k]
                self.palette.clamp_(strokes, at)
                self.x[at, :k] = strokes
        return losses

    def _objective(self) -> tuple[Tensor, dict[str, Tensor]]:
        canvas = self.blend(self.x[self.at, :self.k], self.shown, self.background, self.aimed, self.weight)
        return canvas, self.loss(canvas, self.aimed)


class FixedSteps(LevelSteps):
    """Each step the whole level. ``capture``: replay the step as a CUDA graph after :data:`WARMUP`
    eager ones (on a GPU, with a :func:`capturable` optimizer)."""

    def __init__(self, *args, capture: bool):
        super().__init__(*args)
        device = self.x.device
        self.exists = to_device(self.exists, device)
        self.counts = self.exists.sum(1)  # (B,)
        self.order = torch.arange(self.exists.shape[1], device=device)  # (K,)
        self.blocks = torch.arange(len(self.x), device=device)  # (B,)
        self.shown = torch.zeros_like(self.exists)  # (B, K): the strokes the next steps composite
        self.live = torch.zeros(len(self.x), 1, 1, 1, dtype=self.x.dtype, device=device)  # 1: a block the steps move
        self.replay = Replay(self._step, capture)

    def aim(self, k: int, least: int) -> None:
        """Set on the device from the level's counts: nothing read back or copied in."""
        torch.logical_and(self.exists, self.order < k, out=self.shown)
        self.live.copy_((self.counts >= least).view_as(self.live))

    def __call__(self) -> dict[str, Tensor]:
        return {name: value.clone() for name, value in self.replay().items()}  # a replay overwrites its own

    def _step(self) -> dict[str, Tensor]:
        canvas, losses = step_strokes(self.x, self.optimizer, self._objective, self.keep)
        with torch.no_grad():
            self.canvas.copy_(torch.where(self.live > 0, canvas, self.canvas))
            if self.palette is not None:
                self.palette.clamp_(self.x, self.blocks)
        return losses

    def _objective(self) -> tuple[Tensor, dict[str, Tensor]]:
        canvas = self.blend(self.x, self.shown, self.under, self.goal, self.weights * self.live)
        scale = len(self.x) / self.live.sum()  # block means over the moving blocks: the others add 0
        return canvas, {name: value * scale for name, value in self.loss(canvas, self.goal).items()}


def capturable(optimizer: Optimizer) -> bool:
    """Whether ``optimizer``'s step is the same work every step, as a CUDA graph replays it: this
    package's :class:`RMSprop` without bias correction (whose rate changes a step), a ``torch.optim``
    optimizer made with ``capturable=True``."""
    if isinstance(optimizer, RMSprop):
        return not optimizer.corrected
    groups = getattr(optimizer, "param_groups", None)
    return bool(groups) and all(group.get("capturable", False) for group in groups)


class Replay:
    """``step()`` -> {name: tensor}, the same work on the same tensors each call: eager, or, with
    ``capture`` (on a GPU), eager :data:`WARMUP` times on a side stream, then captured as a CUDA
    graph and replayed, returning the same tensors each call, overwritten. A step that cannot be
    captured (an op that reads the device back, or copies host data in) stays eager, and so do the
    process's later ones: said once."""

    failed = False  # a capture failed in this process: later levels' steps are not tried again

    def __init__(self, step: Callable[[], dict[str, Tensor]], capture: bool):
        self.step, self.capture, self.eager = step, capture and not Replay.failed, 0
        self.graph: torch.cuda.CUDAGraph | None = None
        self.out: dict[str, Tensor] = {}

    def __call__(self) -> dict[str, Tensor]:
        if self.graph is not None:
            self.graph.replay()
            return self.out
        if not self.capture:
            return self.step()
        if self.eager < WARMUP:
            self.eager += 1
            side = torch.cuda.Stream()
            side.wait_stream(torch.cuda.current_stream())
            with torch.cuda.stream(side):
                out = self.step()
            torch.cuda.current_stream().wait_stream(side)
            return out
        try:
            graph = torch.cuda.CUDAGraph()
            with torch.cuda.graph(graph, capture_error_mode="thread_local"):
                self.out = self.step()
        except RuntimeError as error:
            log.warning("painting steps run eagerly: the step could not be captured as a CUDA graph (%s)",
                        str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__)
            self.capture, Replay.failed = False, True
            return self.step()
        self.graph = graph
        graph.replay()  # a capture records the step; it does not take it
        return self.out
