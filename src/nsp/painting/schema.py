"""Structured-config schema of ``python -m nsp.paint``, registered in Hydra's ConfigStore: a misspelt
key or a value of the wrong type fails at compose time, naming the key."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING

from nsp.config import BACKBONES, MODES, BrushConfig  # also registers the ``brush`` group

# Typed choices: Hydra rejects any other value when it composes, listing these.
StyleMode = StrEnum("StyleMode", {mode: mode for mode in MODES})
Backbone = StrEnum("Backbone", {name: name for name in BACKBONES})
Split = StrEnum("Split", {"uniform": "uniform", "error": "error"})  # how a level's strokes are shared among its blocks
RendererName = StrEnum("RendererName", {name: name for name in ("analytic", "neural")})


@dataclass
class RendererConfig:
    """``renderer=analytic`` (the soft vector engine) or ``renderer=neural`` (an ``nsp.train`` checkpoint)."""

    name: RendererName = RendererName.analytic
    softness: Optional[float] = None  # analytic: edge width in block pixels; None: the brush's own (Brush.softness)
    block_size: int = 64  # analytic: blocks are optimized at most this many pixels wide
    # analytic: the soft shading, forward and back, by its compiled kernels (nsp.engine.raster.AnySizeShade), faster:
    # true, compiled first where this machine has none (20–60 s a brush, once a machine); null (auto): those it has,
    # eagerly where it has none, saying which `python -m nsp.engine BRUSH` compiles them; false, never
    compile: Optional[bool] = None
    checkpoint: Optional[str] = None  # neural: path of the checkpoint (required)


@dataclass
class LossConfig:
    """L = l1·L1 + ot·L_ot (paper: 1 and 0.1; ``loss=l1_ot``); the transportation loss on an
    ot_grid² grid, ε = ot_eps, ot_iters Sinkhorn iterations: the one place these defaults live."""

    l1: float = 1.0
    ot: float = 0.0
    ot_grid: int = 48
    ot_eps: float = 0.01
    ot_iters: int = 5


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
    # the last level works on a canvas finer than work_size (up to render_size) until its blocks are
    # this many pixels a side: detail many strokes need (a 3000-stroke level has 13-px blocks at 256); 0: never
    detail_side: int = 32
    # this share of the strokes goes to a level of finer blocks over the faces found (nsp.painter.faces),
    # painted last: eyes and a mouth at 500 strokes; 0: no face search
    face_share: float = 0.08
    palette: bool = True  # stroke colours stay within the target's around each stroke


@dataclass
class StyleConfig:
    """Paint in the style of ``image`` (paper §3.5); ``image: null`` paints without style.

    Both modes recolour the painting with one map shared by every stroke (nsp.painter.stylize);
    ``full`` then optimizes every parameter for the style's texture. ``weight`` (β_sty) is the one
    content/style balance: 0 keeps the photo's lightness (and, in full mode, adds no texture);
    larger values give the style's tones and texture more say. docs/style.md measures it.
    """

    image: Optional[str] = None
    mode: StyleMode = StyleMode.full  # full: every stroke parameter; color: a shared recolouring, shapes kept
    weight: float = 0.5  # β_sty (paper 0.5): colour mode gives up at most β/5 of the luminance SSIM for the style's colours; full: style loss weight
    steps: int = 200  # full mode's optimizer steps (paper 200); colour mode takes none
    size: int = 128  # long side of the canvas the style steps run on (CPU-friendly)
    backbone: Backbone = Backbone.auto  # vgg19 (ImageNet weights, offline), random (no weights), or auto: vgg19 where its weights are found
    weights: Optional[str] = None  # VGG-19 state dict; None: the torch hub cache


@dataclass
class PaintConfig:
    """``python -m nsp.paint``'s keys. The five a user sets most (image, strokes, background,
    render_size, seed) have their defaults in conf/paint/paint.yaml, where they read first; the
    others here. Each default lives in one place."""

    image: str = MISSING  # a PNG/JPEG path, or a built-in photo (see nsp.images.BUILTIN)
    brush: BrushConfig = MISSING
    strokes: int = MISSING
    background: str = MISSING  # the canvas colour: black, white or #rrggbb
    render_size: int = MISSING  # long side of final.png and painting.svg
    work_size: int = 256  # long side of the canvas the strokes are optimized on
    animation_size: int = 512  # long side of animation.gif
    # animation.gif's frames after the empty canvas: at most this many, the same number of strokes
    # each (the last maybe fewer); None: one frame per stroke
    animation_frames: Optional[int] = 100
    seed: int = MISSING
    # torch CPU threads; None: every core for one painting (torch's default, OMP_NUM_THREADS
    # honoured), one per job in a sweep (its jobs run side by side, a core each)
    threads: Optional[int] = None
    device: str = "cpu"  # cpu, cuda, cuda:N or auto (the GPU torch sees, else the CPU)
    progress: bool = True
    renderer: RendererConfig = field(default_factory=RendererConfig)
    loss: LossConfig = field(default_factory=LossConfig)
    schedule: ScheduleConfig = field(default_factory=ScheduleConfig)
    style: StyleConfig = field(default_factory=StyleConfig)
    optimizer: Any = MISSING  # a ``_partial_`` torch optimizer, from the ``optimizer`` group
    task: Any = None  # a painting experiment's ``_partial_`` procedure cfg -> metrics (conf/paint/experiment)
    output_dir: str = "${hydra:runtime.output_dir}"


ConfigStore.instance().store(name="paint_schema", node=PaintConfig)

SCORE_SIZE = 256  # long side at which the painting is compared with its photo (nsp.painter.outputs.similarity)


def searches_faces(cfg: Any) -> bool:
    """Whether a painting of ``cfg`` looks for faces: its ``face_share`` of the strokes is one or more."""
    return round(cfg.schedule.face_share * cfg.strokes) > 0


def photo_side(cfg: Any) -> int:
    """The long side a painting of ``cfg`` reads its photo at: the largest it is used at (the
    working canvas, final.png, the scores, the style's size)."""
    return max(cfg.work_size, cfg.render_size, SCORE_SIZE, cfg.style.size if cfg.style.image else 0)


def follows_checkpoint(cfg: Any, brush_named: bool) -> bool:
    """Whether a painting of ``cfg`` takes its brush from ``renderer.checkpoint`` (a trained renderer
    paints the brush it learned), ``brush_named`` saying whether the caller named a brush."""
    return cfg.renderer.name == "neural" and cfg.renderer.checkpoint is not None and not brush_named
