"""``python -m nsp.paint image=photo.jpg brush=oilpaint strokes=500``: paint a photo with vector
strokes (paper §3).

Config: ``conf/paint/paint.yaml``; results in the Hydra run dir: ``final.png``, ``strokes.json``,
``painting.svg``, ``animation.gif``, ``metrics.json``, ``tensorboard/``, ``paint.log``. The work's
modules (torch) are imported only once the command line has been read.
"""
from __future__ import annotations

import logging
import sys
from pathlib import Path

from omegaconf import MISSING, DictConfig

from nsp.cli import INTERRUPTED, Usage, chosen, command, finish, run_job
from nsp.text import counted

log = logging.getLogger("nsp.paint")  # Hydra sends it to the console and paint.log

TEXT = ("image", "background", "style.image", "brush.texture", "renderer.checkpoint", "hydra.run.dir", "hydra.sweep.dir")

USAGE = Usage(
    summary="Paint a photo with vector brush strokes; writes final.png, painting.svg, animation.gif, "
            "strokes.json, metrics.json and TensorBoard logs into the run dir.",
    examples=(
        "  # the astronaut, 500 oilpaint strokes",
        "image=photo.jpg brush=watercolor strokes=1000",
        "image=photo.jpg style.image=starry.jpg  # in the style of a painting",
        "-m image=a.jpg,b.jpg  # several images, one process per core",
    ),
    keys={
        "image=PATH": "a PNG/JPEG, or astronaut | chelsea | coffee | rocket | flower | china",
        "strokes=N": "how many strokes (500)",
        "background=COLOUR": "the canvas: white, black or #rrggbb",
        "render_size=PX": "long side of final.png and painting.svg (1024)",
        "animation_size=PX": "long side of animation.gif (512)",
        "animation_frames=N": "at most N frames, the same strokes each (100); null: a frame per stroke",
        "style.image=PATH": "paint in the style of this image",
        "seed=N": "the one source of randomness (0)",
        "device=NAME": "cpu, cuda, cuda:N or auto (cpu)",
        "hydra.run.dir=DIR": "where the files go (outputs/paint/<time>_<brush>)",
    },
    groups={
        "brush": "the brush the strokes are painted with",
        "renderer": "the vector engine itself, or a network from nsp.train (renderer.checkpoint=PATH)",
        "loss": "what the strokes are fitted by: L1, or L1 + optimal transport (the paper's)",
        "schedule": "blocks from coarse to fine, or a single level",
        "optimizer": "the strokes' optimizer",
        "experiment": "a paper experiment instead of a painting (run with -m)",
    },
)


def opening(argv: list[str]) -> str:
    """The first line of a run, shown before the work's modules load."""
    image, strokes, brush = (chosen(argv, "paint", key) for key in ("image", "strokes", "brush"))
    if None in (image, strokes, brush):
        return f"starting {' '.join(['python -m nsp.paint', *argv])}…"
    return f"painting {image} with {counted(strokes, brush + ' stroke')}…"


def main(cfg: DictConfig) -> float | None:
    import torch
    from hydra.utils import instantiate

    from nsp.painter.run import paint

    if cfg.task is not None:  # a painting experiment (experiment=ot_push, ot_digits, renderer_painting)
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
        metrics = run_job(cfg, instantiate(cfg.task))
        if metrics is not None:
            log.info(f"{cfg.output_dir}: " + ", ".join(f"{key} {value}" for key, value in metrics.items()))
        return None if metrics is None else metrics.get("psnr", 0.0)
    try:
        metrics = run_job(cfg, paint)  # its last line tells what was painted, how well, how fast, where
    except KeyboardInterrupt:
        kept = [name for name in ("strokes.json", "final.png") if (Path(cfg.output_dir) / name).is_file()]
        print(f"interrupted: {' and '.join(kept)} of what was painted in {cfg.output_dir}" if kept else
              "interrupted before painting began; nothing written", file=sys.stderr)
        sys.exit(INTERRUPTED)
    return None if metrics is None else metrics["psnr"]  # None: a failed job of a sweep, recorded in its dir


def schema() -> object:
    """The structured config the command line is checked against (registers ``paint_schema``)."""
    from nsp.config import BrushConfig
    from nsp.painter.schema import PaintConfig

    return PaintConfig(brush=BrushConfig(MISSING))


def cli() -> None:
    """The command line: ``python -m nsp.paint``."""
    command("paint", main, schema, USAGE, text=TEXT, opening=opening)


if __name__ == "__main__":
    cli()
    finish()
