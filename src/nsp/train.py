"""``python -m nsp.train renderer=R brush=B``: train a neural stroke renderer (paper §3.2).

Config: ``conf/train/train.yaml``; results in the Hydra run dir (``metrics.json``, ``checkpoints/``,
``tensorboard/``).
"""
from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

from nsp.cli import INTERRUPTED, command, run_job
from nsp.config import CONF
from nsp.training import train
from nsp.training.schema import key_tree, register_configs

register_configs()


@hydra.main(config_path=str(CONF / "train"), config_name="train", version_base="1.3")
def main(cfg: DictConfig) -> float | None:
    try:
        metrics = run_job(cfg, train)  # a bad value the schema cannot type (e.g. model.size=48): one line, no traceback
    except KeyboardInterrupt:
        last = Path(cfg.output_dir) / "checkpoints" / "last.ckpt"
        print(f"interrupted: resume with ckpt_path={last} hydra.run.dir={cfg.output_dir}" if last.is_file() else
              "interrupted before training began; nothing saved", file=sys.stderr)
        sys.exit(INTERRUPTED)
    if metrics is None:  # a failed job of a sweep, recorded in its dir
        return None
    print(f"trained {metrics['renderer']} on {metrics['brush']}: {metrics['steps']} steps in {metrics['seconds']:.0f} s, "
          f"test PSNR {metrics['test/psnr']:.2f} dB (validation {metrics['val/psnr']:.2f}): {cfg.output_dir} "
          f"(metrics.json, checkpoints/best.ckpt, last.ckpt)")
    return metrics["val/psnr"]


def cli() -> None:
    """The command line: ``python -m nsp.train``."""
    command(main, CONF / "train", key_tree(), text=("ckpt_path", "brush.texture", "hydra.run.dir", "hydra.sweep.dir"))


if __name__ == "__main__":
    cli()
