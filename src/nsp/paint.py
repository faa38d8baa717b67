"""``python -m nsp.paint image=photo.jpg brush=oilpaint strokes=500``: paint a photo with vector
strokes (paper §3). Config: ``conf/paint/paint.yaml``; results in the Hydra run dir. The work's
modules (torch) are imported only once the command line has been read, and kept out of the garbage
collector's walks.
"""
from __future__ import annotations

import gc
import logging
import sys
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from nsp.cli import INTERRUPTED, command, kept, program, run_job
from nsp.config import BrushConfig
from nsp.painting.schema import PaintConfig, follows_checkpoint, paint_settings  # config only: no torch
from nsp.signals import numpy_before_torch
from nsp.text import counted

log = logging.getLogger("nsp.paint")  # Hydra sends it to the console and paint.log

TEXT = ("image", "background", "paints", "style.image", "brush.texture", "renderer.checkpoint", "hydra.run.dir", "hydra.sweep.dir")


def main(cfg: DictConfig) -> float | None:
    """The command's job: a painting, or a painting experiment (``task``); its PSNR, for a sweeper."""
    named = "brush" in {o.lstrip("+~").split("=", 1)[0].split(".")[0] for o in HydraConfig.get().overrides.task}
    if cfg.task is None and not kept(cfg):  # the first line, before the work's modules load (seconds)
        what = f"{cfg.strokes} strokes of the checkpoint's brush" if follows_checkpoint(cfg, named) else counted(cfg.strokes, cfg.brush.name + " stroke")
        log.info(f"painting {cfg.image} with {what}…")
    numpy_before_torch()
    gc.disable()  # torch's hundreds of thousands of objects are never garbage: collections walking them as they
    from hydra.utils import instantiate  # load, and again while painting, took 0.4 s of the demo's 4.9 (2026-11-28)

    from nsp.painting.run import paint
    gc.freeze()
    gc.enable()

    if cfg.task is not None:  # a painting experiment (experiment=ot_push, ot_digits, renderer_painting)
        metrics = run_job(cfg, instantiate(cfg.task))
        if metrics is not None:
            log.info(f"{cfg.output_dir}: " + ", ".join(f"{key} {value}" for key, value in metrics.items()))
        return None if metrics is None else metrics.get("psnr", 0.0)
    try:
        metrics = run_job(cfg, lambda cfg: paint(paint_settings(cfg), brush_named=named))  # its last line tells what was painted, how well, how fast, where
    except KeyboardInterrupt:
        saved = [name for name in ("strokes.json", "final.png") if (Path(cfg.output_dir) / name).is_file()]
        print(f"interrupted: {' and '.join(saved)} of what was painted in {cfg.output_dir}" if saved else
              "interrupted before painting began; nothing written", file=sys.stderr)
        sys.exit(INTERRUPTED)
    return None if metrics is None else metrics["psnr"]  # None: a failed job of a sweep, recorded in its dir


def schema() -> DictConfig:
    """The structured config the command line is checked against (importing it registered ``paint_schema``)."""
    return OmegaConf.merge(PaintConfig, {"brush": BrushConfig})


def cli() -> None:
    """The command line: ``python -m nsp.paint``."""
    command("paint", main, schema, text=TEXT)


def run() -> None:
    """``python -m nsp.paint`` and ``nsp-paint``: :func:`cli` as the whole process (:func:`nsp.cli.program`)."""
    program(cli)


if __name__ == "__main__":
    run()
