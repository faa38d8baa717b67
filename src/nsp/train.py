"""``python -m nsp.train renderer=R brush=B``: train a neural stroke renderer (paper §3.2). Config:
``conf/train/train.yaml``; results in the Hydra run dir. Lightning and torch are imported only once
the command line has been read.
"""
from __future__ import annotations

import logging
import sys
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from nsp.cli import INTERRUPTED, command, first_rank, kept, run_job
from nsp.signals import numpy_before_torch

log = logging.getLogger("nsp.train")  # Hydra sends it to the console and train.log


def main(cfg: DictConfig) -> float | None:
    choices = HydraConfig.get().runtime.choices  # the first line, before Lightning and torch load (seconds)
    again = kept(cfg)  # a job an earlier run of its sweep completed: run_job says so, and it is not trained
    speaks = first_rank()  # the other processes of a distributed run say nothing the first does not
    if not again and speaks:
        log.info(f"training renderer {choices.renderer} on {choices.brush} strokes, preset {choices.preset}…")
    numpy_before_torch()
    from nsp.training.run import train

    try:
        metrics = run_job(cfg, train)  # a bad value the schema cannot type (e.g. model.size=48): one line, no traceback
    except KeyboardInterrupt:
        last = Path(cfg.output_dir) / "checkpoints" / "last.ckpt"
        if speaks:
            print(f"interrupted: resume with ckpt_path={last} hydra.run.dir={cfg.output_dir}" if last.is_file() else
                  "interrupted before training began; nothing saved", file=sys.stderr)
        sys.exit(INTERRUPTED)
    if metrics is None or again or not speaks:  # a failed job of a sweep, recorded in its dir; a kept one
        return None if metrics is None else metrics.get("val/psnr")
    saved = ", ".join(p.name for name in ("best.ckpt", "last.ckpt") if (p := Path(cfg.output_dir) / "checkpoints" / name).is_file())
    log.info(f"trained {metrics['renderer']} on {metrics['brush']}: {metrics['steps']} steps in {metrics['seconds']:.0f} s, "
             f"test PSNR {metrics['test/psnr']:.2f} dB (validation {metrics['val/psnr']:.2f}): {cfg.output_dir} "
             f"(metrics.json, checkpoints/{saved})")
    return metrics["val/psnr"]


def schema() -> object:
    """Every key a training config can have (registers ``train_schema`` and its parts)."""
    from nsp.training.schema import key_tree, register_configs

    register_configs()
    return key_tree()


def cli() -> None:
    """The command line: ``python -m nsp.train``."""
    command("train", main, schema, text=("ckpt_path", "brush.texture", "hydra.run.dir", "hydra.sweep.dir"))


if __name__ == "__main__":
    cli()
