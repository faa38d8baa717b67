"""A painting run: check the inputs, paint (paper §3), style (§3.5), write the painting's files.

``paint(cfg)`` is what ``python -m nsp.paint`` runs; it needs a composed ``nsp.paint`` config
(``output_dir`` set), not Hydra. What it tells (the phases, the closing summary) goes through
:mod:`logging`: under Hydra, to the console and the run dir's ``paint.log``.
"""
from __future__ import annotations

import logging
import math
import time
from pathlib import Path

import torch
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from torch.utils.tensorboard import SummaryWriter

from nsp.brushes import get_brush
from nsp.colors import parse_color
from nsp.engine.device import resolve_device
from nsp.engine.memory import STYLE_BYTES, WORK_BYTES, check_canvas
from nsp.errors import BadInput
from nsp.files import write_json
from nsp.images import load_image, long_side, resize
from nsp.io.export import frame_ends, write_png
from nsp.painter.callbacks import ProgressBar, TensorBoard
from nsp.painter.faces import find_faces
from nsp.painter.losses import PaintLoss
from nsp.painter.outputs import write_files, write_strokes_and_png
from nsp.painter.painter import Painter
from nsp.painter.renderer import build_renderer
from nsp.painter.schema import follows_checkpoint, photo_side, searches_faces
from nsp.renderers.checkpoint import checkpoint_brush
from nsp.painter.stylize import stylize
from nsp.signals import shielded
from nsp.style import MIN_SIDE, StyleLoss, WeightsNotFound
from nsp.style.features import chosen_backbone
from nsp.style.recolor import ColorSettings
from nsp.text import counted

POSITIVE = ("strokes", "render_size", "work_size", "animation_size", "animation_frames", "renderer.softness",
            "renderer.block_size", "schedule.max_per_block")

MIN_WORK_SIZE = 16  # the coarsest canvas strokes are optimized on, in pixels

log = logging.getLogger(__name__)


def prepare(cfg: DictConfig, photo: torch.Tensor | None = None) -> tuple[Painter, torch.Tensor, torch.Tensor | None, StyleLoss | None]:
    """Check every input; build the painter, the photo (3, H, W), the style image (3, h, w) and
    full mode's style loss (``None`` without ``style.image``; the loss ``None`` in colour mode, which
    needs no feature network); writes nothing. ``photo`` (3, H, W) in [0, 1], if given, is painted
    instead of ``cfg.image`` (which then only names it).

    Raises :class:`BadInput` naming the value and what is valid.
    """
    for key in POSITIVE:
        value = OmegaConf.select(cfg, key)
        if value is not None and value <= 0:  # None: animation_frames' frame per stroke
            raise BadInput(f"{key}={value}: expected a positive number")
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
    if min(s.steps_per_stroke, s.polish, s.overlap, s.detail_side) < 0:
        raise BadInput(f"schedule.steps_per_stroke={s.steps_per_stroke}, schedule.polish={s.polish}, "
                       f"schedule.overlap={s.overlap}, schedule.detail_side={s.detail_side}: expected ≥ 0")
    if not 0 <= s.face_share < 1:
        raise BadInput(f"schedule.face_share={s.face_share}: expected a share of the strokes in [0, 1) (0: faces get no level of their own)")
    if s.growth < 1 or s.crowd < 1 or s.candidates < 1:
        raise BadInput(f"schedule.growth={s.growth}, schedule.crowd={s.crowd}, schedule.candidates={s.candidates}: "
                       "expected ≥ 1 (1: the paper's 1, 2, 3 … levels; a block's share at most crowd × the level's "
                       "mean; candidates 1: each stroke starts at the largest error)")
    if len(s.init_size) != 2 or not 0 < s.init_size[0] <= s.init_size[1] <= 1:
        raise BadInput(f"schedule.init_size={list(s.init_size)}: expected [low, high] with 0 < low ≤ high ≤ 1")
    if s.grids is not None and (not s.grids or min(s.grids) < 1):
        raise BadInput(f"schedule.grids={list(s.grids)}: expected blocks per side of each level, e.g. [1, 2, 3]")
    device = resolve_device(cfg.device)
    try:
        parse_color(cfg.background)
        brush = get_brush(cfg.brush.name, cfg.brush.texture, seed=cfg.seed, impasto=cfg.brush.impasto)
        largest = photo_side(cfg)
        if photo is None:
            photo = load_image(cfg.image, max_side=largest)
        elif max(photo.shape[-2:]) > largest:
            photo = resize(photo, largest)
        check_canvas(*long_side(*photo.shape[-2:], cfg.work_size), "work_size", cover=0, pixel_bytes=WORK_BYTES,
                     noun="working canvas")
        check_canvas(*long_side(*photo.shape[-2:], cfg.render_size), "render_size")  # before hours of painting
        check_canvas(*long_side(*photo.shape[-2:], cfg.animation_size), "animation_size",
                     frames=len(frame_ends(cfg.strokes, cfg.animation_frames)))
        renderer = build_renderer(cfg.renderer, brush, device, cfg.strokes)
        if cfg.style.steps < 0 or cfg.style.size <= 0:
            raise BadInput(f"style.steps={cfg.style.steps}, style.size={cfg.style.size}: expected steps ≥ 0, size > 0")
        if cfg.style.weight < 0:
            raise BadInput(f"style.weight={cfg.style.weight}: expected β_sty ≥ 0 (0 keeps the photo's tones; the paper's 0.5)")
        image = style = None
        if cfg.style.image is not None:
            image = load_image(cfg.style.image, max_side=cfg.style.size, key="style.image")
            for key, picture in (("image", photo), ("style.image", image)):
                shape = long_side(*picture.shape[-2:], cfg.style.size)
                if min(shape) < MIN_SIDE:
                    short, long = sorted(picture.shape[-2:])  # short − 1: it may have been read shrunk, its aspect rounded
                    need = math.ceil(MIN_SIDE * long / max(short - 1, 0.5))
                    raise BadInput(f"style.size={cfg.style.size}: {key} is {shape[0]}×{shape[1]} px at that size, under the "
                                   f"{MIN_SIDE} px a side style transfer needs; use style.size={need} or more")
            check_canvas(*long_side(*photo.shape[-2:], cfg.style.size), "style.size", cover=0,
                         pixel_bytes=STYLE_BYTES if cfg.style.mode == "full" else WORK_BYTES, noun="styled canvas")
            image = resize(image, cfg.style.size).to(device)
            if cfg.style.mode == "full":
                if cfg.style.backbone == "auto":
                    log.info("style.backbone=auto: VGG-19, its weights found" if chosen_backbone("auto", cfg.style.weights) == "vgg19"
                             else "style.backbone=auto: no VGG-19 weights here, so random features (style.backbone=vgg19 says how to get them)")
                style = StyleLoss(image[None], cfg.style.backbone, cfg.style.weights, cfg.seed).to(device)
    except (ValueError, WeightsNotFound) as error:
        raise BadInput(str(error)) from None
    loss = PaintLoss.from_config(cfg.loss, parse_color(cfg.background))
    painter = Painter(brush, renderer, loss, instantiate(cfg.optimizer), schedule=OmegaConf.to_object(cfg.schedule),
                      background=cfg.background, generator=torch.Generator().manual_seed(cfg.seed))
    return painter, photo.to(device), image, style


def settings(cfg: DictConfig) -> dict[str, str | int | float]:
    """The run's key settings, as its TensorBoard HPARAMS entry shows them."""
    return {"image": str(cfg.image), "brush": cfg.brush.name, "strokes": cfg.strokes, "renderer": str(cfg.renderer.name),
            "loss.l1": cfg.loss.l1, "loss.ot": cfg.loss.ot, "schedule.steps_per_stroke": cfg.schedule.steps_per_stroke,
            "schedule.polish": cfg.schedule.polish,
            "work_size": cfg.work_size, "optimizer.lr": cfg.optimizer.get("lr", 0.0), "seed": cfg.seed,
            "style.image": str(cfg.style.image)}


def paint_style(cfg: DictConfig, painter: Painter, strokes: torch.Tensor, photo: torch.Tensor, image: torch.Tensor,
                style: StyleLoss | None, writer: SummaryWriter) -> tuple[torch.Tensor, str, float]:
    """Restyle the painted ``strokes`` (N, d) toward ``image`` (3, h, w), with full mode's style
    loss ``style``; logs ``style/*`` curves; returns new strokes, the canvas colour recoloured with
    them, and the seconds they took."""
    color = cfg.style.mode == "color"
    steps = ColorSettings().map_steps + ColorSettings().stroke_steps if color else cfg.style.steps
    with ProgressBar(steps, cfg.progress, "recolouring steps" if color else "style steps") as bar:
        def log_step(step: int, losses: dict[str, float]) -> None:
            for name, value in losses.items():
                writer.add_scalar(f"style/{name}", value, step)
            bar.advance(1, f"style {losses['style']:.3f}")

        strokes, background = stylize(painter.brush, strokes, resize(photo, cfg.style.size), image, painter.loss,
                                      instantiate(cfg.optimizer), loss=style, weight=cfg.style.weight, steps=cfg.style.steps,
                                      mode=cfg.style.mode, background=cfg.background, softness=cfg.renderer.softness,
                                      seed=cfg.seed, callbacks=[log_step], tick=lambda: bar.advance(1, "recolouring"))
    return strokes, background, bar.seconds


def paint(cfg: DictConfig, photo: torch.Tensor | None = None, brush_named: bool = True) -> dict:
    """Paint ``cfg.image`` (or ``photo``, as :func:`prepare` takes it); write the painting's files into
    ``cfg.output_dir``; return the metrics (``seconds``: the whole run, the checks and files included).
    Unless ``brush_named``, a trained renderer paints with its checkpoint's brush (:func:`follows_checkpoint`).

    Interrupted (Ctrl-C, SIGTERM) or failing part-way, it still writes ``strokes.json`` and
    ``final.png`` of what was painted (no stroke yet: the bare canvas), then re-raises.
    """
    start = time.perf_counter()
    if follows_checkpoint(cfg, brush_named):
        cfg.brush.name = checkpoint_brush(cfg.renderer.checkpoint)
    painter, photo, image, style = prepare(cfg, photo)
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    target = resize(photo, cfg.work_size)
    brush, background = painter.brush, cfg.background  # styled strokes may come with a background of their own
    phases = []  # what took how long, as the bars showed it
    with SummaryWriter(out) as writer:  # events in the run dir: TensorBoard names the run after it
        board = TensorBoard(writer, target)
        with ProgressBar(cfg.strokes, cfg.progress) as bar:  # the painting's time: its face search too
            painter.callbacks += [board, bar]
            try:
                faces = find_faces(target) if searches_faces(cfg) else []
                strokes = painter.paint(target, cfg.strokes, detail=resize(photo, cfg.render_size), faces=faces)
            except BaseException:
                with shielded():
                    write_strokes_and_png(out, painter.strokes(), brush, photo.shape[-2:], background, cfg.render_size)
                    board.flush()
                raise
        painting = bar.seconds
        on_faces = f" ({counted(len(faces), 'face')} given a level of {'its' if len(faces) == 1 else 'their'} own)" if faces else ""
        phases.append(f"painted {counted(len(strokes), painter.brush.name + ' stroke')}{on_faces} in {painting:.1f} s")
        try:  # from here to the last file, an interruption or a failure still leaves what was painted
            if image is not None:
                write_png(out / "style.png", image)
                styled, background, seconds = paint_style(cfg, painter, strokes, photo, image, style, writer)
                strokes = styled  # the canvas recoloured with them
                phases.append(f"styled in {seconds:.1f} s")
            frames = len(frame_ends(len(strokes), cfg.animation_frames))
            log.info(f"writing final.png, strokes.json, painting.svg, animation.gif ({frames} frames)…")
            files = time.perf_counter()
            scores = write_files(out, strokes, brush, photo, background, cfg.render_size, cfg.animation_size,
                                 cfg.animation_frames, workers=min(3, torch.get_num_threads()),
                                 compile=cfg.renderer.compile)
        except BaseException:
            with shielded():
                write_strokes_and_png(out, strokes, brush, photo.shape[-2:], background, cfg.render_size)  # styled, if it was
            raise
        phases.append(f"wrote the files in {time.perf_counter() - files:.1f} s")
        board.log_run(settings(cfg), scores)
    metrics = scores | {"seconds": round(time.perf_counter() - start, 2), "painting_seconds": round(painting, 2),
                        "strokes": len(strokes), "faces": len(faces), "threads": torch.get_num_threads()}
    write_json(out / "metrics.json", metrics)
    log.info(f"{', '.join(phases)}: PSNR {scores['psnr']:.2f} dB, SSIM {scores['ssim']:.3f}; {out}")
    return metrics
