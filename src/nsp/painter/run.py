"""A painting run: check the inputs, paint (paper §3), style (§3.5), write the painting's files.

``paint(cfg)`` is what ``python -m nsp.paint`` runs; it needs a composed ``nsp.paint`` config
(``output_dir`` set), not Hydra.
"""
from __future__ import annotations

import time
from pathlib import Path

import torch
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from torch.utils.tensorboard import SummaryWriter

from nsp.brushes import get_brush
from nsp.cli import shielded
from nsp.engine import parse_color
from nsp.engine.memory import check_canvas
from nsp.errors import BadInput
from nsp.io.export import write_json, write_png
from nsp.painter.callbacks import ProgressBar, TensorBoard
from nsp.painter.images import load_image, long_side, resize
from nsp.painter.losses import PaintLoss
from nsp.painter.outputs import SCORE_SIZE, similarity, write_strokes_and_png, write_vector_files
from nsp.painter.painter import Painter
from nsp.painter.renderer import AnalyticRenderer, load_neural
from nsp.painter.stylize import stylize
from nsp.style import StyleLoss, WeightsNotFound, load_style_image

POSITIVE = ("strokes", "render_size", "work_size", "animation_size", "animation_frames", "renderer.softness",
            "renderer.block_size", "schedule.max_per_block")

MIN_WORK_SIZE = 16  # the coarsest canvas strokes are optimized on, in pixels


def prepare(cfg: DictConfig) -> tuple[Painter, torch.Tensor, StyleLoss | None]:
    """Check every input; build the painter, the photo (3, H, W) and the style loss (``None``
    without ``style.image``); writes nothing.

    Raises :class:`BadInput` naming the value and what is valid.
    """
    for key in POSITIVE:
        if OmegaConf.select(cfg, key) <= 0:
            raise BadInput(f"{key}={OmegaConf.select(cfg, key)}: expected a positive number")
    if cfg.work_size < MIN_WORK_SIZE:
        raise BadInput(f"work_size={cfg.work_size}: expected at least {MIN_WORK_SIZE} pixels")
    if cfg.threads is not None and cfg.threads < 1:
        raise BadInput(f"threads={cfg.threads}: expected a positive number of threads, or null for torch's default")
    if cfg.optimizer.get("lr", 1) <= 0:
        raise BadInput(f"optimizer.lr={cfg.optimizer.lr}: expected a positive learning rate")
    loss = cfg.loss
    if loss.l1 < 0 or loss.ot < 0 or loss.ot_grid < 2 or loss.ot_eps <= 0 or loss.ot_iters < 1:
        raise BadInput(f"loss.l1={loss.l1}, loss.ot={loss.ot}, loss.ot_grid={loss.ot_grid}, loss.ot_eps={loss.ot_eps}, "
                       f"loss.ot_iters={loss.ot_iters}: expected weights ≥ 0, a grid of ≥ 2, eps > 0, iters ≥ 1")
    s = cfg.schedule
    if s.steps_per_stroke < 0 or s.overlap < 0:
        raise BadInput(f"schedule.steps_per_stroke={s.steps_per_stroke}, schedule.overlap={s.overlap}: expected ≥ 0")
    if len(s.init_size) != 2 or not 0 < s.init_size[0] <= s.init_size[1] <= 1:
        raise BadInput(f"schedule.init_size={list(s.init_size)}: expected [low, high] with 0 < low ≤ high ≤ 1")
    if s.grids is not None and (not s.grids or min(s.grids) < 1):
        raise BadInput(f"schedule.grids={list(s.grids)}: expected blocks per side of each level, e.g. [1, 2, 3]")
    try:
        parse_color(cfg.background)
        brush = get_brush(cfg.brush.name, cfg.brush.texture)
        photo = load_image(cfg.image, max_side=max(cfg.work_size, SCORE_SIZE, cfg.style.size if cfg.style.image else 0))
        check_canvas(*long_side(*photo.shape[-2:], cfg.render_size), "render_size")  # before hours of painting
        check_canvas(*long_side(*photo.shape[-2:], cfg.animation_size), "animation_size", frames=cfg.animation_frames + 1)
        if cfg.renderer.name == "analytic":
            renderer = AnalyticRenderer(brush, cfg.renderer.softness, cfg.renderer.block_size)
        elif cfg.renderer.checkpoint is None:
            raise BadInput(f"renderer=neural needs renderer.checkpoint=PATH, from `python -m nsp.train brush={brush.name}`")
        else:
            renderer = load_neural(cfg.renderer.checkpoint, brush)
        if cfg.style.steps < 0 or cfg.style.size <= 0:
            raise BadInput(f"style.steps={cfg.style.steps}, style.size={cfg.style.size}: expected steps ≥ 0, size > 0")
        style = None
        if cfg.style.image is not None:
            style = StyleLoss(load_style_image(cfg.style.image, cfg.style.size), cfg.style.backbone, cfg.style.weights,
                              cfg.seed, cfg.style.color_weight if cfg.style.mode == "color" else 0.0)
    except (ValueError, WeightsNotFound) as error:
        raise BadInput(str(error)) from None
    loss = PaintLoss.from_config(cfg.loss, parse_color(cfg.background))
    painter = Painter(brush, renderer, loss, instantiate(cfg.optimizer), grids=s.grids, max_per_block=s.max_per_block,
                      overlap=s.overlap, steps_per_stroke=s.steps_per_stroke, init_size=s.init_size,
                      background=cfg.background, generator=torch.Generator().manual_seed(cfg.seed))
    return painter, photo, style


def paint_style(cfg: DictConfig, painter: Painter, strokes: torch.Tensor, photo: torch.Tensor, style: StyleLoss,
                writer: SummaryWriter) -> torch.Tensor:
    """The style steps on the painted ``strokes`` (N, d); logs ``style/*`` curves; returns new strokes."""
    with ProgressBar(cfg.style.steps, cfg.progress, "style steps") as bar:
        def log(step: int, losses: dict[str, float]) -> None:
            for name, value in losses.items():
                writer.add_scalar(f"style/{name}", value, step)
            bar.advance(1, f"style {losses['style']:.3f}")

        return stylize(painter.brush, strokes, resize(photo, cfg.style.size), painter.loss, style,
                       instantiate(cfg.optimizer), weight=cfg.style.weight, steps=cfg.style.steps,
                       mode=cfg.style.mode, background=cfg.background, softness=cfg.renderer.softness, callbacks=[log])


def paint(cfg: DictConfig) -> dict:
    """Paint ``cfg.image``; write the painting's files into ``cfg.output_dir``; return the metrics.

    Interrupted (Ctrl-C, SIGTERM) or failing part-way, it still writes ``strokes.json`` and
    ``final.png`` of what was painted (no stroke yet: the bare canvas), then re-raises.
    """
    start = time.perf_counter()
    painter, photo, style = prepare(cfg)
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    target = resize(photo, cfg.work_size)
    shared = (painter.brush, photo.shape[-2:], cfg.background, cfg.render_size)  # brush, aspect, background, size
    with SummaryWriter(out / "tensorboard") as writer, ProgressBar(cfg.strokes, cfg.progress) as bar:
        painter.callbacks += [TensorBoard(writer), bar]
        try:
            strokes = painter.paint(target, cfg.strokes)
        except BaseException:
            with shielded():
                write_strokes_and_png(out, painter.strokes(), *shared)
            raise
        if style is not None:
            write_png(out / "style.png", style.image[0])
            try:
                strokes = paint_style(cfg, painter, strokes, photo, style, writer)
            except BaseException:
                with shielded():
                    write_strokes_and_png(out, strokes, *shared)  # the unstyled painting
                raise
    final = write_strokes_and_png(out, strokes, *shared)
    write_vector_files(out, strokes, *shared, cfg.animation_size, cfg.animation_frames)
    metrics = similarity(final, photo) | {"seconds": round(time.perf_counter() - start, 2), "strokes": len(strokes)}
    write_json(out / "metrics.json", metrics)
    return metrics
