"""Stroke search (paper §3): strokes are optimized by gradient descent so that, composited in order,
they reproduce the target; progressively, from one block to finer grids of blocks.

Each level paints all its blocks as one batch (blocks × active strokes × pixels). A level's strokes
are shared among its blocks by the error left when it starts (or equally, as in the paper). Strokes
join a block's active set one at a time: each is tried at a few regions of large error and lengths,
and the one that lowers the block's error most joins; after each addition the whole active set takes
``steps_per_stroke`` optimizer steps (paper §3.6: 20), each stroke's colours kept within the target's
around it. Once every stroke is placed, all the level's strokes take ``polish`` more steps together
(the last added would otherwise have had the fewest). A finished level, rendered by the vector engine,
is the background of the next; a last level of small blocks may work on a finer canvas
(``detail_side``). Faces found in the photo (:mod:`nsp.painter.faces`) get a last level of their own.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable, Sequence

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import parse_color
from nsp.engine import paint_canvas
from nsp.engine.device import to_device
from nsp.images import long_side, resize
from nsp.painter.blocks import Level, distribute, grid_shape, progressive_grids, share
from nsp.painter.faces import Box
from nsp.painter.optimize import Optimizer, moving
from nsp.painter.palette import Palette
from nsp.painter.placement import Forms, place_strokes
from nsp.painter.settings import ScheduleConfig
from nsp.painter.steps import FixedSteps, FreeSteps, capturable

LENGTHS = (0.5, 1.0, 2.0)  # a candidate stroke per length at each error peak, × the reach of the colour there
FACE_GRID = 4  # a face level has at least this many blocks along the largest face (eyes, nose, mouth: 2–4 px strokes)


class Callback:
    """Hooks the painter calls while it works (logging, progress); each does nothing by default."""

    def on_strokes(self, painter: "Painter", added: int) -> None:
        """``added`` strokes joined the active sets."""

    def on_step(self, painter: "Painter", step: int, losses: dict[str, Tensor]) -> None:
        """Optimizer step ``step`` (over all levels) was taken with these block-mean losses, 0-dim tensors
        on the device: a read waits for it, so read a level's at once (``on_level``), not one a step."""

    def on_level(self, painter: "Painter", level: int, canvas: Tensor) -> None:
        """Level ``level`` (0-based) is done; ``canvas`` (3, H, W) is everything painted so far."""


class Painter:
    """Paints a target with strokes of one brush.

    Args:
        renderer: ``renderer.resolution(side) -> size``, ``renderer.composite(x, shown, under)``
            (each block's strokes painted in order over it) and ``renderer.gains(x, block, canvas, goal,
            weights)`` (the error each stroke alone takes away): see :mod:`nsp.painter.renderer`.
        loss: ``loss(canvas, target) -> {"total": scalar, ...}`` on (B, 3, h, w) blocks.
        optimizer: builds the optimizer of a list of parameters (e.g. a ``_partial_`` RMSprop).
        schedule: the levels and how each stroke is added and optimized (:class:`ScheduleConfig`).
        background: canvas colour.
        generator: the only source of randomness (new strokes' sizes, angles, directions).
        callbacks: see :class:`Callback`.
        trainable: indices of the parameters optimized; ``None``: all (style's colour mode: the colours).
    """

    def __init__(self, brush: Brush, renderer, loss: Callable[[Tensor, Tensor], dict[str, Tensor]],
                 optimizer: Callable[[list[Tensor]], Optimizer], *, schedule: ScheduleConfig | None = None,
                 background: str = "white", generator: torch.Generator | None = None,
                 callbacks: Sequence[Callback] = (), trainable: Sequence[int] | None = None):
        self.brush, self.renderer, self.loss, self.optimizer = brush, renderer, loss, optimizer
        self.schedule, self.background = schedule if schedule is not None else ScheduleConfig(), background
        self.generator = generator if generator is not None else torch.Generator().manual_seed(0)
        self.callbacks = list(callbacks)
        self.frozen = [] if trainable is None else [i for i in range(brush.d) if i not in set(trainable)]
        self.step = 0
        self._done: list[Tensor] = []  # finished levels' strokes, whole-canvas parameters
        self._active: tuple[Level, Tensor, Tensor, int] | None = None  # level, x, painted mask, size

    def levels(self, strokes: int, height: int, width: int, finest: int | None = None,
               faces: Sequence[Box] = ()) -> list[Level]:
        """The schedule for ``strokes`` strokes on a height×width canvas; counts sum to ``strokes``.
        ``finest``: the longest side the last levels' canvas may have (see ``detail_side``); ``faces``:
        boxes that get a level of their own, last (see ``face_share``), the others sharing the rest."""
        s = self.schedule
        on_faces = round(s.face_share * strokes) if faces else 0
        strokes -= on_faces
        grids = list(s.grids) if s.grids else progressive_grids(strokes, height, width, s.max_per_block, s.growth)
        blocks = [rows * cols for rows, cols in (grid_shape(m, height, width) for m in grids)]
        levels = [Level.grid(m, height, width, s.overlap, n) for m, n in zip(grids, distribute(strokes, blocks))]
        last, count = grids[-1], int(levels[-1].counts.sum())
        levels[-1] = self._detailed(lambda h, w: Level.grid(last, h, w, s.overlap,
                                                            distribute(count, [math.prod(grid_shape(last, h, w))])[0]),
                                    height, width, finest)
        if on_faces:
            grid = max(FACE_GRID, math.ceil(math.sqrt(on_faces / s.max_per_block)))
            levels.append(self._detailed(lambda h, w: Level.regions(faces, grid, h, w, on_faces), height, width, finest))
        return levels

    def _detailed(self, level: Callable[[int, int], Level], height: int, width: int, finest: int | None) -> Level:
        """``level(h, w)`` on the height×width canvas, or on a finer one (long side up to ``finest``)
        where its blocks would be under ``detail_side`` pixels; its strokes are shared among its
        blocks there again."""
        coarse = level(height, width)
        scale = 0.0 if finest is None else min(self.schedule.detail_side / coarse.side, finest / max(height, width))
        return level(*long_side(height, width, round(max(height, width) * scale))) if scale > 1 else coarse

    def paint(self, target: Tensor, strokes: int, detail: Tensor | None = None, faces: Sequence[Box] = ()) -> Tensor:
        """Paint ``target`` (3, H, W) in [0, 1] with exactly ``strokes`` strokes: (strokes, d) in [0, 1],
        whole-canvas parameters in painting order (interrupted, :meth:`strokes` still returns what was
        painted). With ``detail``, the same picture at a finer size (3, H', W'), the last levels may
        work on it, downsampled (see ``detail_side``); ``faces`` (e.g. from
        :func:`nsp.painter.faces.find_faces`) get a level of their own (see ``face_share``)."""
        _, height, width = target.shape
        self._done, self._active, self.step = [], None, 0
        color = to_device(torch.tensor(parse_color(self.background), dtype=target.dtype, device="cpu"), target.device)
        canvas = color[:, None, None].expand(3, height, width)
        finest = None if detail is None else max(detail.shape[-2:])  # detail_side 0: levels() keeps the canvas
        for index, level in enumerate(self.levels(strokes, height, width, finest, faces)):
            if (level.height, level.width) != (height, width):  # a finer last level: the painting so far, on its canvas
                height, width = level.height, level.width
                target = resize(detail, (height, width))
                with torch.no_grad():
                    canvas = paint_canvas(self.brush.plain(), self.strokes(), height, width, self.background)
            x = self._paint_level(level, target, canvas)
            with torch.no_grad():  # the mean of the bristles: blocks are sampled down to the working size
                canvas = paint_canvas(self.brush.plain(), x, height, width, canvas=canvas)
            self._done.append(x)
            self._active = None
            for callback in self.callbacks:
                callback.on_level(self, index, canvas)
        return self.strokes()

    def strokes(self) -> Tensor:
        """(N, d): every stroke painted so far, the current level's active sets included."""
        parts = list(self._done)
        if self._active is not None:
            level, x, painted, size = self._active
            parts.append(_in_order(level.to_canvas(x.detach(), self.brush.kinds, size), painted))
        return torch.cat(parts) if parts else torch.empty(0, self.brush.d)

    def _paint_level(self, level: Level, target: Tensor, canvas: Tensor) -> Tensor:
        """Optimize one level's blocks together; returns its strokes, whole-canvas, in painting order."""
        size = self.renderer.resolution(level.side)
        goal = level.crop(target, size)  # (B, 3, s, s)
        under = level.crop(canvas, size)
        weights = level.weights(size, target)  # padding is scored as if painted right
        if self.schedule.split == "error":
            level = self._by_error(level, under, goal, weights)
        counts = level.counts.tolist()  # the level's bookkeeping is the host's: no step waits for the device
        depth, device = max(counts), target.device
        exists = torch.arange(depth, device="cpu")[None] < level.counts[:, None]  # (B, K), as level.counts: the CPU
        x = torch.zeros(level.blocks, depth, self.brush.d, device=device, requires_grad=True)
        optimizer = self.optimizer([x])
        forms = Forms.of(goal)
        palette = Palette(self.brush, forms.colors, max(5, round(self.schedule.init_size[1] * size))) if self.schedule.palette else None  # a long stroke wide
        painted = torch.zeros_like(exists)
        self._active = (level, x, painted, size)
        current = under.clone()
        lives = [[b for b, count in enumerate(counts) if count > k] for k in range(depth)]  # the blocks taking stroke k
        ats = to_device(torch.tensor(sum(lives, []), device="cpu"), device).split([len(live) for live in lives])  # a copy
        level_steps = (x, optimizer, moving(x, self.frozen), self._blend, self.loss, under, goal, weights, exists, current,
                       palette)
        if self.schedule.static if self.schedule.static is not None else device.type != "cpu":
            steps = FixedSteps(*level_steps, capture=device.type == "cuda" and capturable(optimizer))
        else:
            steps = FreeSteps(*level_steps, taking=ats)

        def optimize(k: int, least: int, count: int) -> None:
            """``count`` steps of the first k strokes of the blocks with at least ``least``."""
            steps.aim(k, least)
            for _ in range(count):
                scalars = steps()
                self.step += 1
                for callback in self.callbacks:
                    callback.on_step(self, self.step, scalars)

        for k, (live, at) in enumerate(zip(lives, ats)):
            with torch.no_grad():
                x[at, k] = self._place(current[at], goal[at], weights[at], forms[at])
            painted[:, k] = exists[:, k]
            for callback in self.callbacks:
                callback.on_strokes(self, len(live))
            if not self.schedule.steps_per_stroke:
                with torch.no_grad():
                    current[at] = self._blend(x[at, : k + 1], None, under[at], goal[at], weights[at])
            optimize(k + 1, k + 1, self.schedule.steps_per_stroke)
        optimize(depth, 1, self.schedule.polish)  # the whole level together
        return _in_order(level.to_canvas(x.detach(), self.brush.kinds, size), exists)

    def _place(self, canvas: Tensor, goal: Tensor, weights: Tensor, forms: Forms) -> Tensor:
        """A new stroke for each block (B, 3, s, s each; weights (B, 1, s, s); the goal's ``forms``):
        (B, d), the candidate that, rendered once on the canvas, leaves the least error."""
        s = self.schedule
        if s.candidates == 1:
            return place_strokes(self.brush, canvas, goal, weights, s.init_size, self.generator, forms=forms)
        tried = place_strokes(self.brush, canvas, goal, weights, s.init_size, self.generator, s.candidates, LENGTHS,
                              forms)  # (B, C, d)
        blocks, count, d = tried.shape
        block = torch.arange(blocks, device=tried.device).repeat_interleave(count)
        gains = self.renderer.gains(tried.reshape(-1, d), block, canvas, goal, weights).view(blocks, count)
        return tried[torch.arange(blocks, device=tried.device), gains.argmax(1)]

    def _by_error(self, level: Level, under: Tensor, goal: Tensor, weights: Tensor) -> Level:
        """The level with its strokes shared by the mean |canvas − target| left in each block
        (B, 3, s, s each; weights (B, 1, s, s)), at most ``crowd`` times the mean per block."""
        error = ((under - goal).abs().sum(1, keepdim=True) * weights).sum((1, 2, 3)) / weights.sum((1, 2, 3))
        strokes = int(level.counts.sum())
        cap = max(1, math.ceil(self.schedule.crowd * strokes / level.blocks))
        return dataclasses.replace(level, counts=share(strokes, error, cap))

    def _blend(self, x: Tensor, shown: Tensor | None, under: Tensor, goal: Tensor, weights: Tensor) -> Tensor:
        """Composite each block's strokes x (B, k, d) in order over it, ``under`` (B, 3, s, s), those
        ``shown`` (B, k) (None: all): (B, 3, s, s); padding shows the target."""
        return weights * self.renderer.composite(x, shown, under) + (1 - weights) * goal


def _in_order(x: Tensor, painted: Tensor) -> Tensor:
    """The painted strokes of x (B, K, d) in painting order: (N, d), interleaved across blocks (every
    block's first stroke, then every second, …), so a level fills in everywhere at once and each
    block's later, finer strokes stay on top of its neighbours' earlier, broader ones where they overlap."""
    return x.transpose(0, 1)[painted.T]
