"""The painter's typed settings: its renderer, its loss and its schedule. Each checks itself when
made (``OmegaConf.to_object`` makes them from ``python -m nsp.paint``'s config), raising
:class:`~nsp.errors.BadInput` that names the value and what is valid. No torch here: ``--help`` reads it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Optional, Union

from nsp.config import compile_choice
from nsp.errors import BadInput

Split = StrEnum("Split", {"uniform": "uniform", "error": "error"})  # how a level's strokes are shared among its blocks
RendererName = StrEnum("RendererName", {name: name for name in ("analytic", "neural")})


def positive(**values: float | None) -> None:
    """:class:`BadInput` for the first of ``values`` (key=value) that is not a positive number; None passes."""
    for key, value in values.items():
        if value is not None and value <= 0:
            raise BadInput(f"{key}={value}: expected a positive number")


@dataclass
class RendererConfig:
    """``renderer=analytic`` (the soft vector engine) or ``renderer=neural`` (an ``nsp.train`` checkpoint)."""

    name: RendererName = RendererName.analytic
    softness: Optional[float] = None  # analytic: edge width in block pixels; None: the brush's own (Brush.softness)
    block_size: int = 64  # analytic: blocks are optimized at most this many pixels wide
    # analytic: the soft shading, forward and back, by its compiled kernels (nsp.engine.raster.AnySizeShade): true,
    # compiled first where this machine has none; auto: those it has, eagerly where it has none, saying which
    # `python -m nsp.engine BRUSH` compiles them; false, never. Made, it holds True, False, or None for auto.
    compile: Union[bool, str, None] = "auto"
    # analytic: true, every stroke shaded on its whole block, no read back a step; false, culled on the host; null: on a GPU
    static: Optional[bool] = None
    checkpoint: Optional[str] = None  # neural: path of the checkpoint (required)

    def __post_init__(self) -> None:
        positive(**{"renderer.softness": self.softness, "renderer.block_size": self.block_size})
        self.compile = compile_choice(self.compile, "renderer.compile")


@dataclass
class LossConfig:
    """L = l1·L1 + ot·L_ot (paper: 1 and 0.1; ``loss=l1_ot``); the transportation loss on an
    ot_grid² grid, ε = ot_eps, ot_iters Sinkhorn iterations: the one place these defaults live."""

    l1: float = 1.0
    ot: float = 0.0
    ot_grid: int = 48
    ot_eps: float = 0.01
    ot_iters: int = 5

    def __post_init__(self) -> None:
        if self.l1 < 0 or self.ot < 0 or self.ot_grid < 2 or self.ot_eps <= 0 or self.ot_iters < 1:
            raise BadInput(f"loss.l1={self.l1}, loss.ot={self.ot}, loss.ot_grid={self.ot_grid}, loss.ot_eps={self.ot_eps}, "
                           f"loss.ot_iters={self.ot_iters}: expected weights ≥ 0, a grid of ≥ 2, eps > 0, iters ≥ 1")


@dataclass
class ScheduleConfig:
    """Levels of blocks (``grids``: m per level; None: m = 1, then each ×growth rounded up, the fewest
    levels with ≤ max_per_block strokes per block), how a level's strokes are shared among its
    blocks, and how each stroke is added and optimized."""

    grids: Optional[list[int]] = None
    max_per_block: int = 6
    growth: float = 1.4  # each level's m over the last's (1: the paper's 1, 2, 3, …)
    overlap: float = 0.0  # blocks are this much larger than their grid cells (the paper overlaps them)
    split: Split = Split.error  # error: by the error left in each block; uniform: equally (paper)
    crowd: float = 2.0  # split=error: the most strokes a block takes, × the level's mean
    steps_per_stroke: int = 8  # optimizer steps of the active set after each added stroke (paper: 20)
    polish: int = 4  # optimizer steps of each level's strokes together once all are placed (paper: 0)
    init_size: list[float] = field(default_factory=lambda: [0.1, 0.3])  # new strokes' lengths, × block width
    candidates: int = 4  # regions of large error a new stroke is tried at (3 lengths each); the best one starts
    # the last level works on a canvas finer than work_size (up to render_size) until its blocks are this many
    # pixels a side: detail many strokes need (a 3000-stroke level has 13-px blocks at 256); 0: never
    detail_side: int = 32
    face_share: float = 0.08  # of the strokes, for a last level of finer blocks over the faces found; 0: no search
    palette: bool = True  # stroke colours stay within the target's around each stroke
    # true: each step of a level takes the whole level, its shape fixed (strokes not yet placed hidden, blocks done
    # weighted 0; the same strokes), replayed as a CUDA graph on a GPU; false: only the strokes it moves; null: on a GPU
    static: Optional[bool] = None

    def __post_init__(self) -> None:
        positive(**{"schedule.max_per_block": self.max_per_block})
        if min(self.steps_per_stroke, self.polish, self.overlap, self.detail_side) < 0:
            raise BadInput(f"schedule.steps_per_stroke={self.steps_per_stroke}, schedule.polish={self.polish}, "
                           f"schedule.overlap={self.overlap}, schedule.detail_side={self.detail_side}: expected ≥ 0")
        if not 0 <= self.face_share < 1:
            raise BadInput(f"schedule.face_share={self.face_share}: expected a share of the strokes in [0, 1) "
                           "(0: faces get no level of their own)")
        if self.growth < 1 or self.crowd < 1 or self.candidates < 1:
            raise BadInput(f"schedule.growth={self.growth}, schedule.crowd={self.crowd}, schedule.candidates="
                           f"{self.candidates}: expected ≥ 1 (1: the paper's 1, 2, 3 … levels; a block's share at most "
                           "crowd × the level's mean; candidates 1: each stroke starts at the largest error)")
        if len(self.init_size) != 2 or not 0 < self.init_size[0] <= self.init_size[1] <= 1:
            raise BadInput(f"schedule.init_size={list(self.init_size)}: expected [low, high] with 0 < low ≤ high ≤ 1")
        if self.grids is not None and (not self.grids or min(self.grids) < 1):
            raise BadInput(f"schedule.grids={list(self.grids)}: expected blocks per side of each level, e.g. [1, 2, 3]")
