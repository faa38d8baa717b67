"""Structured-config schema of ``python -m nsp.paint``, registered in Hydra's ConfigStore: a misspelt
key or a value of the wrong type fails at compose time, naming the key; a value out of range fails
when ``OmegaConf.to_object`` makes the typed :class:`PaintConfig` (:func:`paint_settings`), naming it."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING, DictConfig, OmegaConf

from nsp.config import BACKBONES, MODES, PAINT_ORDERS, BrushConfig, check_paints  # also registers the ``brush`` group
from nsp.errors import BadInput
from nsp.painter.settings import LossConfig, RendererConfig, ScheduleConfig, positive

MIN_WORK_SIZE = 16  # the coarsest canvas strokes are optimized on, in pixels
SCORE_SIZE = 256  # long side at which the painting is compared with its photo (nsp.painting.outputs.similarity)

# Typed choices: Hydra rejects any other value when it composes, listing these.
StyleMode = StrEnum("StyleMode", {mode: mode for mode in MODES})
Backbone = StrEnum("Backbone", {name: name for name in BACKBONES})
PaintOrder = StrEnum("PaintOrder", {order: order for order in PAINT_ORDERS})


@dataclass
class StyleConfig:
    """Paint in the style of ``image`` (paper §3.5); ``image: null`` paints without style. Both modes
    recolour the painting with one map shared by every stroke (nsp.painter.stylize); ``full`` then
    optimizes every parameter for the style's texture. ``weight`` (β_sty) is the one content/style
    balance: 0 keeps the photo's lightness (and adds no texture); docs/style.md measures it."""

    image: Optional[str] = None
    mode: StyleMode = StyleMode.full  # full: every stroke parameter; color: a shared recolouring, shapes kept
    weight: float = 0.5  # β_sty (paper 0.5): colour mode gives up at most β/5 of the luminance SSIM for the style's colours; full: style loss weight
    steps: int = 200  # full mode's optimizer steps (paper 200); colour mode takes none
    size: int = 128  # long side of the canvas the style steps run on (CPU-friendly)
    backbone: Backbone = Backbone.auto  # vgg19 (ImageNet weights, offline), random (no weights), or auto: vgg19 where its weights are found
    weights: Optional[str] = None  # VGG-19 state dict; None: the torch hub cache

    def __post_init__(self) -> None:
        if self.steps < 0 or self.size <= 0:
            raise BadInput(f"style.steps={self.steps}, style.size={self.size}: expected steps ≥ 0, size > 0")
        if self.weight < 0:
            raise BadInput(f"style.weight={self.weight}: expected β_sty ≥ 0 (0 keeps the photo's tones; the paper's 0.5)")


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
    threads: Optional[int] = None  # torch CPU threads; None: torch's default, one a job in a sweep run side by side
    device: str = "cpu"  # cpu, cuda, cuda:N or auto (the GPU torch sees, else the CPU)
    progress: bool = True
    renderer: RendererConfig = field(default_factory=RendererConfig)
    loss: LossConfig = field(default_factory=LossConfig)
    schedule: ScheduleConfig = field(default_factory=ScheduleConfig)
    style: StyleConfig = field(default_factory=StyleConfig)
    # every stroke one of K paints (2–32) chosen for the photo, or of yours ([#rrggbb, …]), laid down paint
    # by paint in paint_order (final.png shows that order), plot.svg a layer a paint; null: any colour
    paints: Any = None
    paint_order: PaintOrder = PaintOrder.light_to_dark  # light_to_dark, dark_to_light, or listed: as paints=[…] lists them
    paint_steps: int = 400  # steps choosing the strokes' paints (half), then polishing the layered strokes (and chosen paints)
    opaque: bool = False  # paint as opaque media do: every stroke covers what is under it (alpha 1, no glaze)
    optimizer: Any = MISSING  # a ``_partial_`` torch optimizer, from the ``optimizer`` group
    task: Any = None  # a painting experiment's ``_partial_`` procedure cfg -> metrics (conf/paint/experiment)
    output_dir: str = "${hydra:runtime.output_dir}"

    def __post_init__(self) -> None:
        positive(strokes=self.strokes, render_size=self.render_size, animation_size=self.animation_size,
                 animation_frames=self.animation_frames)
        if self.work_size < MIN_WORK_SIZE:
            raise BadInput(f"work_size={self.work_size}: expected at least {MIN_WORK_SIZE} pixels")
        if self.optimizer.get("lr", 1) <= 0:
            raise BadInput(f"optimizer.lr={self.optimizer['lr']}: expected a positive learning rate")
        if self.paints is not None:
            check_paints(self.paints)
            if self.style.image is not None:
                raise BadInput(f"paints={self.paints} with style.image={self.style.image}: a style recolours every stroke, "
                               "which a set of paints cannot follow; drop one of them")
        if self.opaque and self.brush.glaze:
            raise BadInput(f"opaque=true with brush.glaze={self.brush.glaze}: opaque paint covers what is under it, "
                           "a glaze filters it; drop one of them")
        if self.paint_steps < 0:
            raise BadInput(f"paint_steps={self.paint_steps}: expected 0 or more steps")
        if self.renderer.name == "neural" and self.renderer.checkpoint is None:
            raise BadInput("renderer=neural needs renderer.checkpoint=PATH, from "
                           f"`python -m nsp.train brush={self.brush.name}`")


ConfigStore.instance().store(name="paint_schema", node=PaintConfig)


def paint_settings(cfg: DictConfig) -> PaintConfig:
    """A composed ``nsp.paint`` config as the typed :class:`PaintConfig` the painting reads, each
    value checked (:class:`BadInput` naming the first out of range)."""
    return OmegaConf.to_object(OmegaConf.merge(PaintConfig, cfg))  # typed, where a copy of it had lost its type


def follows_checkpoint(cfg: Any, brush_named: bool) -> bool:
    """Whether a painting of ``cfg`` takes its brush from ``renderer.checkpoint`` (a trained renderer
    paints the brush it learned), ``brush_named`` saying whether the caller named a brush."""
    return cfg.renderer.name == "neural" and cfg.renderer.checkpoint is not None and not brush_named
