"""The checks of a composed training config that its types cannot make."""
from __future__ import annotations

from typing import Any

import torch

from nsp.engine.memory import check_training
from nsp.errors import BadInput

ACCELERATORS = ("cpu", "gpu", "cuda", "mps", "auto")


def check(cfg: Any) -> None:
    """Raise ``ValueError`` (one line naming the value and what is valid) for sizes and counts that would
    train nothing or wrongly, a GPU the machine lacks, or memory it lacks (:mod:`nsp.engine.memory`)."""
    data, model = cfg.data, cfg.model
    for key in ("batch_size", "epoch_size", "val_size", "test_size"):
        if data[key] < 1:
            raise BadInput(f"data.{key}={data[key]}: expected a positive number of strokes")
    if data.epoch_size < data.batch_size:
        raise BadInput(f"data.epoch_size={data.epoch_size} is less than one batch (data.batch_size={data.batch_size})")
    if data.num_workers < 0:
        raise BadInput(f"data.num_workers={data.num_workers}: expected 0 (render in the training process) or more")
    if model.channel_mult <= 0:
        raise BadInput(f"model.channel_mult={model.channel_mult}: expected a positive channel-width multiplier (1 = the paper's)")
    if cfg.renderer.size != model.size:
        raise BadInput(f"renderer.size={cfg.renderer.size} differs from model.size={model.size}: set model.size, "
                         f"the renderer and the training strokes follow it")
    if model.optimizer.get("lr", 1) <= 0:
        raise BadInput(f"model.optimizer.lr={model.optimizer.lr}: expected a positive learning rate")
    accelerator = cfg.trainer.accelerator
    if accelerator not in ACCELERATORS:
        raise BadInput(f"trainer.accelerator={accelerator}: expected one of {', '.join(ACCELERATORS)}")
    if accelerator in ("gpu", "cuda") and not torch.cuda.is_available():
        raise BadInput(f"trainer.accelerator={accelerator}: this machine has no CUDA GPU; use trainer.accelerator=cpu")
    if cfg.threads is not None and cfg.threads < 1:
        raise BadInput(f"threads={cfg.threads}: expected a positive number of threads, or null for torch's default")
    if cfg.trainer.max_steps < -1 or cfg.trainer.max_steps == 0:
        raise BadInput(f"trainer.max_steps={cfg.trainer.max_steps}: expected a positive number of steps, or -1 (no limit)")
    on_cpu = accelerator == "cpu" or (accelerator == "auto" and not torch.cuda.is_available())
    check_training(data.batch_size, data.val_size + data.test_size, model.size, on_cpu)
