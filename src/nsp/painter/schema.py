"""Structured-config schema of ``python -m nsp.paint``, registered in Hydra's ConfigStore: a misspelt
key or a value of the wrong type fails at compose time, naming the key."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING

from nsp.config import BrushConfig  # also registers the ``brush`` group
from nsp.painter.stylize import MODES
from nsp.style import BACKBONES

# Typed choices: Hydra rejects any other value when it composes, listing these.
StyleMode = StrEnum("StyleMode", {mode: mode for mode in MODES})
Backbone = StrEnum("Backbone", {name: name for name in BACKBONES})
RendererName = StrEnum("RendererName", {name: name for name in ("analytic", "neural")})


@dataclass
class RendererConfig:
    """``renderer=analytic`` (the soft vector engine) or ``renderer=neural`` (an ``nsp.train`` checkpoint)."""

    name: RendererName = RendererName.analytic
    softness: float = 0.5  # analytic: edge width in block pixels
    block_size: int = 64  # analytic: blocks are optimized at most this many pixels wide
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
    """Levels of blocks (``grids``: m per level; None: 1…M, M the fewest with ≤ max_per_block
    strokes per block), and how each stroke is added and optimized."""

    grids: Optional[list[int]] = None
    max_per_block: int = 6
    overlap: float = 0.25  # blocks are this much larger than their grid cells
    steps_per_stroke: int = 8  # optimizer steps of the active set after each added stroke (paper: 20)
    init_size: list[float] = field(default_factory=lambda: [0.1, 0.3])  # new strokes' sizes, × block width


@dataclass
class StyleConfig:
    """Paint in the style of ``image`` (paper §3.5); ``image: null`` paints without style."""

    image: Optional[str] = None
    mode: StyleMode = StyleMode.full  # full: every stroke parameter; color: colour parameters only
    weight: float = 0.5  # β_sty (paper 0.5)
    steps: int = 200  # paper 200
    size: int = 128  # long side of the canvas the style steps run on (CPU-friendly)
    backbone: Backbone = Backbone.vgg19  # vgg19 (ImageNet weights, offline) or random (no weights needed)
    weights: Optional[str] = None  # VGG-19 state dict; None: the torch hub cache
    color_weight: float = 2.0  # colour mode: weight of the sliced-Wasserstein colour term


@dataclass
class PaintConfig:
    image: str = "astronaut"  # a PNG/JPEG path, or a built-in photo (see nsp.painter.images.BUILTIN)
    brush: BrushConfig = MISSING
    strokes: int = 500
    background: str = "white"  # the canvas colour: black, white or #rrggbb
    render_size: int = 1024  # long side of final.png and painting.svg
    work_size: int = 256  # long side of the canvas the strokes are optimized on
    animation_size: int = 256  # long side of animation.gif
    animation_frames: int = 50
    seed: int = 0
    # torch CPU threads. Each step's tensors are small: more threads gain little, and on a busy
    # machine they wait on each other (3-5× slower measured with two on two shared cores).
    threads: Optional[int] = 1
    progress: bool = True
    renderer: RendererConfig = field(default_factory=RendererConfig)
    loss: LossConfig = field(default_factory=LossConfig)
    schedule: ScheduleConfig = field(default_factory=ScheduleConfig)
    style: StyleConfig = field(default_factory=StyleConfig)
    optimizer: Any = MISSING  # a ``_partial_`` torch optimizer, from the ``optimizer`` group
    task: Any = None  # a painting experiment's ``_partial_`` procedure cfg -> metrics (conf/paint/experiment)
    output_dir: str = "${hydra:runtime.output_dir}"


ConfigStore.instance().store(name="paint_schema", node=PaintConfig)
