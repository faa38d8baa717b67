"""``python -m nsp.train renderer=R brush=B``: train a neural stroke renderer (SPEC §4, §6).

Config: ``conf/train/train.yaml``; results in the Hydra run dir (``metrics.json``, ``checkpoints/``,
``tensorboard/``).
"""
from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

from nsp.cli import run_job
from nsp.training import train
from nsp.training.schema import misspelt_key, register_configs

register_configs()


@hydra.main(config_path="../../conf/train", config_name="train", version_base="1.3")
def main(cfg: DictConfig) -> float | None:
    metrics = run_job(cfg, train)  # a bad value the schema cannot type (e.g. model.size=48): one line, no traceback
    return None if metrics is None else metrics["val/psnr"]


if __name__ == "__main__":
    if hint := misspelt_key(sys.argv[1:]):
        sys.exit(hint)
    main()
