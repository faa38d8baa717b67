"""Structured-config schemas of ``python -m nsp.train``, registered in Hydra's ConfigStore: a badly typed
value fails at compose time naming its key (:func:`nsp.training.checks.check` catches the others).
Nothing here imports torch: ``--help`` composes this config."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING

from nsp.config import BrushConfig  # also registers the ``brush`` group


@dataclass
class RendererConfig:
    _target_: str = MISSING
    name: str = MISSING  # the group choice (nsp's, or one of yours via hydra.searchpath): keys ``lr_by_renderer``, names the run
    size: int = "${model.size}"  # type: ignore[assignment]
    channel_mult: float = "${model.channel_mult}"  # type: ignore[assignment]


@dataclass
class DualConfig(RendererConfig):
    _target_: str = "nsp.renderers.DualPathway"
    pathways: list[str] = field(default_factory=lambda: ["rasterization", "shading"])
    silhouettes: int = 2  # 2: nsp's support and coverage; 1: the paper's one silhouette (renderer=dual_silhouette)


@dataclass
class DataConfig:
    batch_size: int = 64
    epoch_size: int = 50_000  # fresh random strokes per epoch (the paper's)
    val_size: int = 1024  # fixed, seeded validation strokes
    val_seed: int = 0  # the validation set does not move with ``seed``, so runs compare
    test_size: int = 1024  # fixed, seeded test strokes, scored once after training: tables report these,
    test_seed: int = 0  # while choices (learning rates) are made on the validation strokes
    num_workers: int = 1  # processes rendering training batches alongside training
    render_on_device: bool = False  # render training batches on the training device (GPU) instead
    # draw through the engine's compiled kernels (nsp.engine.fused), faster: true, compiled first where missing (20–60 s
    # once a machine); null, those this machine has (python -m nsp.engine BRUSH compiles them); false, never
    compile: Optional[bool] = False


Interval = StrEnum("Interval", {"epoch": "epoch", "step": "step"})  # Hydra rejects any other at compose time


@dataclass
class ModelConfig:
    size: int = 128  # output side S: 32, 64 or 128
    channel_mult: float = 1.0  # channel multiplier; 1 = the paper's layers
    optimizer: Any = field(default_factory=lambda: {  # fused: one kernel for all parameters, several× faster on CPU
        "_target_": "torch.optim.Adam", "_partial_": True, "lr": 2e-4, "betas": [0.9, 0.999], "fused": True})
    scheduler: Any = None  # LRScheduler _partial_, from the ``schedule`` group
    scheduler_interval: Interval = Interval.epoch  # when the scheduler steps


@dataclass
class TrainerConfig:
    """The ``pytorch_lightning.Trainer`` arguments nsp sets; add others with ``+trainer.key=value``."""

    _target_: str = "pytorch_lightning.Trainer"
    accelerator: str = "cpu"
    devices: Any = 1
    num_nodes: int = 1
    strategy: str = "auto"
    precision: Any = "32-true"
    max_epochs: Optional[int] = None
    max_steps: int = -1
    max_time: Optional[str] = None  # "DD:HH:MM:SS"; studies end on max_steps only, so a busy machine changes no table
    val_check_interval: Any = None
    check_val_every_n_epoch: Optional[int] = 1
    limit_train_batches: Any = None
    limit_val_batches: Any = None
    num_sanity_val_steps: int = 2
    log_every_n_steps: int = 10  # train/* points: 30 in a 300-step run
    gradient_clip_val: Optional[float] = None
    deterministic: Any = False
    benchmark: Optional[bool] = None
    sync_batchnorm: bool = False
    use_distributed_sampler: bool = True
    enable_progress_bar: bool = True
    enable_model_summary: bool = False  # Lightning's layer table; the parameter count is in the summary line


@dataclass
class TrainConfig:
    renderer: RendererConfig = MISSING
    brush: BrushConfig = MISSING
    data: DataConfig = field(default_factory=DataConfig)
    model: ModelConfig = field(default_factory=ModelConfig)
    trainer: TrainerConfig = field(default_factory=TrainerConfig)
    seed: int = 0  # model initialisation and the training strokes
    lr_by_renderer: dict[str, dict[str, float]] = field(default_factory=dict)  # studies: size (``32px``) -> renderer -> its rate (experiment=renderer_lr)
    threads: Optional[int] = None  # torch intra-op threads of the training process; None = torch's default
    ckpt_path: Optional[str] = None  # resume from this checkpoint
    output_dir: str = "${hydra:runtime.output_dir}"


def register_configs() -> None:
    cs = ConfigStore.instance()
    cs.store(name="train_schema", node=TrainConfig)
    cs.store(group="schema/renderer", name="base", node=RendererConfig)
    cs.store(group="schema/renderer", name="dual", node=DualConfig)
    cs.store(group="schema/trainer", name="base", node=TrainerConfig)


def key_tree() -> TrainConfig:
    """Every key a training config can have (the dual renderer's keys are a superset of the others')."""
    return TrainConfig(renderer=DualConfig(), brush=BrushConfig(MISSING))
