"""``python -m nsp.paint image=photo.jpg brush=oilpaint strokes=500``: paint a photo with vector
strokes (SPEC §5, §6; paper §3).

Config: ``conf/paint/paint.yaml``; results in the Hydra run dir: ``final.png``, ``strokes.json``,
``painting.svg``, ``animation.gif``, ``metrics.json``, ``tensorboard/``.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import hydra
import torch
from hydra.utils import instantiate
from omegaconf import DictConfig
from torch.utils.tensorboard import SummaryWriter

from nsp.brushes import get_brush
from nsp.engine import parse_color
from nsp.painter import schema  # noqa: F401  (registers ``paint_schema``)
from nsp.painter.callbacks import ProgressBar, TensorBoard
from nsp.painter.images import load_image, resize
from nsp.painter.losses import PaintLoss
from nsp.painter.outputs import similarity, write_strokes_and_png, write_vector_files
from nsp.painter.painter import Painter
from nsp.painter.renderer import AnalyticRenderer, load_neural


class BadInput(ValueError):
    """A value the painting cannot start with; the message is the one line the user sees."""


def prepare(cfg: DictConfig) -> tuple[Painter, torch.Tensor]:
    """Check every input and build the painter and the photo (3, H, W); writes nothing.

    Raises :class:`BadInput` naming the value and what is valid.
    """
    for key in ("strokes", "render_size", "work_size", "animation_size", "animation_frames"):
        if cfg[key] <= 0:
            raise BadInput(f"{key}={cfg[key]}: expected a positive number")
    try:
        parse_color(cfg.canvas)
        brush = get_brush(cfg.brush.name, cfg.brush.texture)
        photo = load_image(cfg.image)
        if cfg.renderer.name == "analytic":
            renderer = AnalyticRenderer(brush, cfg.renderer.softness, cfg.renderer.block_size)
        else:
            renderer = load_neural(cfg.renderer.checkpoint, brush)
    except ValueError as error:
        raise BadInput(str(error)) from None
    loss = PaintLoss(cfg.loss.l1, cfg.loss.ot, cfg.loss.ot_grid, cfg.loss.ot_eps, cfg.loss.ot_iters,
                     parse_color(cfg.canvas))
    s = cfg.schedule
    painter = Painter(brush, renderer, loss, instantiate(cfg.optimizer), grids=s.grids, max_per_block=s.max_per_block,
                      overlap=s.overlap, steps_per_stroke=s.steps_per_stroke, init_size=s.init_size,
                      background=cfg.canvas, generator=torch.Generator().manual_seed(cfg.seed))
    return painter, photo


def paint(cfg: DictConfig) -> dict:
    """Paint ``cfg.image``; write the painting's files into ``cfg.output_dir``; return the metrics.

    Interrupted (Ctrl-C) or failing part-way, it still writes ``strokes.json`` and ``final.png``
    of what was painted, then re-raises.
    """
    start = time.perf_counter()
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    painter, photo = prepare(cfg)
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    target = resize(photo, cfg.work_size)
    canvas = (painter.brush, photo.shape[-2:], cfg.canvas, cfg.render_size)  # what every file shares
    with SummaryWriter(out / "tensorboard") as writer, ProgressBar(cfg.strokes, cfg.progress) as bar:
        painter.callbacks += [TensorBoard(writer), bar]
        try:
            strokes = painter.paint(target, cfg.strokes)
        except BaseException:
            write_strokes_and_png(out, painter.strokes(), *canvas)
            raise
    final = write_strokes_and_png(out, strokes, *canvas)
    write_vector_files(out, strokes, *canvas, cfg.animation_size, cfg.animation_frames)
    metrics = similarity(final, photo) | {"seconds": round(time.perf_counter() - start, 2), "strokes": len(strokes)}
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    return metrics


@hydra.main(config_path="../../conf/paint", config_name="paint", version_base="1.3")
def main(cfg: DictConfig) -> float:
    try:
        metrics = paint(cfg)
    except BadInput as error:
        sys.exit(f"error: {error}")
    except KeyboardInterrupt:
        print(f"interrupted: strokes.json and final.png of what was painted are in {cfg.output_dir}", file=sys.stderr)
        sys.exit(130)
    print(f"painted {metrics['strokes']} strokes in {metrics['seconds']:.1f} s, PSNR {metrics['psnr']:.2f} dB: "
          f"{cfg.output_dir}")
    return metrics["psnr"]


if __name__ == "__main__":
    main()
