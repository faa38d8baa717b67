"""``python -m nsp.experiments -m experiment=ot_push``: run a painting experiment's ``task``.

Composes ``nsp.paint``'s config (``conf/paint``) with an ``experiment`` file that sets ``task``; every
job writes its ``metrics.json`` and files in its Hydra run dir, like ``nsp.paint``.
"""
from __future__ import annotations

import sys

import hydra
from hydra.utils import instantiate
from omegaconf import DictConfig

from nsp.experiments.schema import register

register()


@hydra.main(config_path="../../../conf/paint", config_name="paint", version_base="1.3")
def main(cfg: DictConfig) -> dict:
    if cfg.task is None:
        sys.exit("error: no task; choose a painting experiment, e.g. experiment=ot_push or experiment=ot_digits")
    metrics = instantiate(cfg.task)(cfg)
    print(f"{cfg.output_dir}: " + ", ".join(f"{key} {value}" for key, value in metrics.items()))
    return metrics


if __name__ == "__main__":
    main()
