"""``python -m nsp.paint image=photo.jpg brush=oilpaint strokes=500``: paint a photo with vector
strokes (paper §3).

Config: ``conf/paint/paint.yaml``; results in the Hydra run dir: ``final.png``, ``strokes.json``,
``painting.svg``, ``animation.gif``, ``metrics.json``, TensorBoard events, ``paint.log``. The work's
modules (torch) are imported only once the command line has been read.
"""
from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from omegaconf import MISSING, DictConfig

from nsp.cli import INTERRUPTED, command, in_sweep, kept, program, run_job, side_by_side, sweeps
from nsp.config import BrushConfig
from nsp.painter.ahead import FilesAhead
from nsp.painter.schema import PaintConfig, follows_checkpoint, photo_side, searches_faces  # config only: no torch
from nsp.signals import numpy_before_torch
from nsp.text import counted

log = logging.getLogger("nsp.paint")  # Hydra sends it to the console and paint.log

AHEAD_STROKES = 100  # fewer are painted about as soon as the files' process has imported torch: no time gained
TEXT = ("image", "background", "style.image", "brush.texture", "renderer.checkpoint", "hydra.run.dir", "hydra.sweep.dir")

def main(cfg: DictConfig, early: FilesAhead | None = None) -> float | None:
    """The command's job; ``early``: the files' process, started before the config was read
    (:func:`cli`), used where the config :func:`writes_ahead`, else closed."""
    named = "brush" in {o.lstrip("+~").split("=", 1)[0].split(".")[0] for o in HydraConfig.get().overrides.task}
    if cfg.task is None and not kept(cfg):  # the first line, before the work's modules load (seconds)
        what = f"{cfg.strokes} strokes of the checkpoint's brush" if follows_checkpoint(cfg, named) else counted(cfg.strokes, cfg.brush.name + " stroke")
        log.info(f"painting {cfg.image} with {what}…")
    ahead = None
    if not writes_ahead(cfg):
        if early is not None:
            early.close()
    else:
        try:
            ahead = early or FilesAhead()  # its import of torch beside this one's
        except OSError as error:  # no process to be had (a limit on processes, on memory): the files come after
            log.warning(f"no process to write the files in while painting ({error.strerror or error}); "
                        "they are written once it is done")
        else:
            ahead.look_for_faces(cfg.image if searches_faces(cfg) else None, photo_side(cfg), cfg.work_size)
    numpy_before_torch()
    import torch
    from hydra.utils import instantiate

    from nsp.painter.run import paint

    if cfg.threads is None and side_by_side():
        cfg.threads = 1  # the sweep's jobs run side by side (joblib, submitit_local), a core each
    if cfg.task is not None:  # a painting experiment (experiment=ot_push, ot_digits, renderer_painting)
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
        metrics = run_job(cfg, instantiate(cfg.task))
        if metrics is not None:
            log.info(f"{cfg.output_dir}: " + ", ".join(f"{key} {value}" for key, value in metrics.items()))
        return None if metrics is None else metrics.get("psnr", 0.0)
    try:
        metrics = run_job(cfg, lambda cfg: paint(cfg, brush_named=named, ahead=ahead))  # its last line tells what was painted, how well, how fast, where
    except KeyboardInterrupt:
        saved = [name for name in ("strokes.json", "final.png") if (Path(cfg.output_dir) / name).is_file()]
        print(f"interrupted: {' and '.join(saved)} of what was painted in {cfg.output_dir}" if saved else
              "interrupted before painting began; nothing written", file=sys.stderr)
        sys.exit(INTERRUPTED)
    finally:
        if ahead is not None:
            ahead.close()
    return None if metrics is None else metrics["psnr"]  # None: a failed job of a sweep, recorded in its dir


def writes_ahead(cfg: DictConfig) -> bool:
    """Whether a single painting of :data:`AHEAD_STROKES` strokes or more, on its default threads,
    on the CPU of a machine of two cores or more, writes its files ahead (:mod:`nsp.painter.ahead`):
    not styled, not a sweep's job (a core each)."""
    return (cfg.task is None and cfg.style.image is None and cfg.threads is None and str(cfg.device) == "cpu"
            and cfg.strokes >= AHEAD_STROKES and not in_sweep() and os.name == "posix" and _cores() > 1)


def _cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def schema() -> object:
    """The structured config the command line is checked against (importing it registered ``paint_schema``)."""
    return PaintConfig(brush=BrushConfig(MISSING))


def cli() -> None:
    """The command line: ``python -m nsp.paint``."""
    early = _early(sys.argv[1:])
    try:
        command("paint", lambda cfg: main(cfg, early), schema, text=TEXT)
    finally:
        if early is not None:
            early.close()


def _early(argv: list[str]) -> FilesAhead | None:
    """The files' process, started before Hydra reads the config, where the line asks for one
    painting (no flag, no sweep) on a machine of two cores or more: it loads the face cascade while
    Hydra composes (0.2 s), so that its faces are found once torch is in. None where it cannot be
    had: :func:`main` starts one, if the config writes ahead, and tells why not."""
    if any(arg.startswith("-") for arg in argv) or sweeps(argv) or os.name != "posix" or _cores() < 2:
        return None
    try:
        return FilesAhead()
    except OSError:
        return None


def run() -> None:
    """``python -m nsp.paint`` and ``nsp-paint``: :func:`cli` as the whole process (:func:`nsp.cli.program`)."""
    program(cli)


if __name__ == "__main__":
    run()
