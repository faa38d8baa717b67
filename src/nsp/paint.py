"""``python -m nsp.paint image=photo.jpg brush=oilpaint strokes=500``: paint a photo with vector
strokes (paper §3).

Config: ``conf/paint/paint.yaml``; results in the Hydra run dir: ``final.png``, ``strokes.json``,
``painting.svg``, ``animation.gif``, ``metrics.json``, ``tensorboard/``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import hydra
from hydra.utils import instantiate
from omegaconf import MISSING, DictConfig

from nsp.cli import INTERRUPTED, command, run_job
from nsp.config import CONF, BrushConfig
from nsp.painter.schema import PaintConfig  # registers ``paint_schema``
from nsp.painter.run import paint

TEXT = ("image", "background", "style.image", "brush.texture", "renderer.checkpoint", "hydra.run.dir", "hydra.sweep.dir")


@hydra.main(config_path=str(CONF / "paint"), config_name="paint", version_base="1.3")
def main(cfg: DictConfig) -> float | None:
    if cfg.task is not None:  # a painting experiment (experiment=ot_push, ot_digits)
        metrics = run_job(cfg, instantiate(cfg.task))
        if metrics is not None:
            print(f"{cfg.output_dir}: " + ", ".join(f"{key} {value}" for key, value in metrics.items()))
        return None if metrics is None else metrics.get("psnr", 0.0)
    try:
        metrics = run_job(cfg, paint)
    except KeyboardInterrupt:
        kept = [name for name in ("strokes.json", "final.png") if (Path(cfg.output_dir) / name).is_file()]
        print(f"interrupted: {' and '.join(kept)} of what was painted in {cfg.output_dir}" if kept else
              "interrupted before painting began; nothing written", file=sys.stderr)
        sys.exit(INTERRUPTED)
    if metrics is None:  # a failed job of a sweep, recorded in its dir
        return None
    print(f"painted {metrics['strokes']} strokes in {metrics['seconds']:.1f} s, PSNR {metrics['psnr']:.2f} dB: "
          f"{cfg.output_dir}")
    return metrics["psnr"]


def cli() -> None:
    """The command line: ``python -m nsp.paint``."""
    command(main, CONF / "paint", PaintConfig(brush=BrushConfig(MISSING)), text=TEXT)


if __name__ == "__main__":
    cli()
