"""A painting run: check the inputs, paint (paper §3), style (§3.5), write the painting's files.

``paint(cfg)`` is what ``python -m nsp.paint`` runs; it needs the typed config
(:func:`nsp.painting.schema.paint_settings`, ``output_dir`` set), not Hydra. What it tells goes
through :mod:`logging`: under Hydra, to the console and the run dir's ``paint.log``.
"""
from __future__ import annotations

import logging
import math
import time
from pathlib import Path
from typing import Sequence

import torch
from hydra.utils import instantiate
from torch.utils.tensorboard import SummaryWriter

from nsp.brushes import get_brush
from nsp.brushes.registry import GLAZING
from nsp.colors import parse_color
from nsp.engine.device import resolve_device
from nsp.engine.memory import STYLE_BYTES, WORK_BYTES, check_canvas
from nsp.errors import BadInput
from nsp.files import write_json
from nsp.images import load_image, long_side, resize
from nsp.io.export import frame_ends, write_png
from nsp.painter.faces import find_faces
from nsp.painter.losses import PaintLoss
from nsp.painter.painter import Callback, Painter
from nsp.painter.paints import LAYER_SIZE, Paints, choose_paints, in_order, lay, parse_paints
from nsp.painter.renderer import build_renderer
from nsp.painter.stylize import stylize
from nsp.painting.callbacks import ProgressBar, TensorBoard
from nsp.painting.outputs import write_files, write_strokes_and_png
from nsp.painting.schema import SCORE_SIZE, PaintConfig, follows_checkpoint
from nsp.renderers.checkpoint import checkpoint_brush
from nsp.signals import shielded
from nsp.style import MIN_SIDE, StyleLoss, WeightsNotFound
from nsp.style.features import chosen_backbone
from nsp.style.recolor import ColorSettings
from nsp.text import counted

log = logging.getLogger(__name__)


def prepare(cfg: PaintConfig, photo: torch.Tensor | None = None) -> tuple[Painter, torch.Tensor, torch.Tensor | None, StyleLoss | None]:
    """Check every input (:class:`BadInput` naming the value and what is valid); build the painter, the
    photo (3, H, W), the style image (3, h, w) and full mode's style loss (``None`` without
    ``style.image``; the loss ``None`` in colour mode); writes nothing. ``photo`` (3, H, W) in
    [0, 1], if given, is painted instead of ``cfg.image`` (which then only names it)."""
    device = resolve_device(cfg.device)
    try:
        parse_color(cfg.background)
        opaque = cfg.opaque and cfg.brush.name in GLAZING
        brush = get_brush(cfg.brush.name, cfg.brush.texture, seed=cfg.seed, impasto=cfg.brush.impasto,
                          glaze=0.0 if opaque else cfg.brush.glaze)
        # the photo's long side: the largest it is used at (working canvas, final.png, scores, style)
        largest = max(cfg.work_size, cfg.render_size, SCORE_SIZE, cfg.style.size if cfg.style.image else 0)
        if photo is None:
            photo = load_image(cfg.image, max_side=largest)
        elif max(photo.shape[-2:]) > largest:
            photo = resize(photo, largest)
        check_canvas(*long_side(*photo.shape[-2:], cfg.work_size), "work_size", cover=0, pixel_bytes=WORK_BYTES,
                     noun="working canvas")
        check_canvas(*long_side(*photo.shape[-2:], cfg.render_size), "render_size")  # before hours of painting
        check_canvas(*long_side(*photo.shape[-2:], cfg.animation_size), "animation_size",
                     frames=len(frame_ends(cfg.strokes, cfg.animation_frames)))
        renderer = build_renderer(cfg.renderer, brush, device)
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
    painter = Painter(brush, renderer, loss, instantiate(cfg.optimizer), schedule=cfg.schedule,
                      background=cfg.background, generator=torch.Generator().manual_seed(cfg.seed),
                      trainable=covering(brush) if cfg.opaque else None)
    return painter, photo.to(device), image, style


def settings(cfg: PaintConfig) -> dict[str, str | int | float]:
    """The run's key settings, as its TensorBoard HPARAMS entry shows them."""
    return {"image": str(cfg.image), "brush": cfg.brush.name, "strokes": cfg.strokes, "renderer": str(cfg.renderer.name),
            "loss.l1": cfg.loss.l1, "loss.ot": cfg.loss.ot, "schedule.steps_per_stroke": cfg.schedule.steps_per_stroke,
            "schedule.polish": cfg.schedule.polish, "work_size": cfg.work_size,
            "optimizer.lr": cfg.optimizer.get("lr", 0.0), "seed": cfg.seed, "style.image": str(cfg.style.image)}


def paint_style(cfg: PaintConfig, painter: Painter, strokes: torch.Tensor, photo: torch.Tensor, image: torch.Tensor,
                style: StyleLoss | None, writer: SummaryWriter) -> tuple[torch.Tensor, str, float]:
    """Restyle ``strokes`` (N, d) toward ``image`` (3, h, w) (full mode's loss ``style``), logging ``style/*``
    curves; returns the new strokes, the canvas colour recoloured with them, and the seconds taken."""
    color = cfg.style.mode == "color"
    steps = ColorSettings().map_steps + ColorSettings().stroke_steps if color else cfg.style.steps
    with ProgressBar(steps, cfg.progress, "recolouring steps" if color else "style steps") as bar:
        def log_step(step: int, losses: dict[str, torch.Tensor]) -> None:
            for name, value in losses.items():
                writer.add_scalar(f"style/{name}", value, step)
            bar.advance(1, f"style {losses['style']:.3f}")

        strokes, background = stylize(painter.brush, strokes, resize(photo, cfg.style.size), image, painter.loss,
                                      instantiate(cfg.optimizer), loss=style, weight=cfg.style.weight, steps=cfg.style.steps,
                                      mode=cfg.style.mode, background=cfg.background, softness=cfg.renderer.softness,
                                      seed=cfg.seed, callbacks=[log_step], tick=lambda: bar.advance(1, "recolouring"))
    return strokes, background, bar.seconds


def covering(brush) -> list[int] | None:
    """The parameters optimized for opaque media (``opaque=true``): all but the alpha, which stays 1 as
    strokes are placed (None: the brush has none)."""
    return None if brush.alpha is None else [i for i in range(brush.d) if i != brush.alpha]


def paint_layers(cfg: PaintConfig, brush, strokes: torch.Tensor, photo: torch.Tensor) -> tuple[torch.Tensor, Paints, float]:
    """The painting ``strokes`` laid in ``cfg.paints`` (:func:`nsp.painter.paints.lay`): the strokes in layer
    order, the paints as laid, and the seconds taken."""
    chosen = not isinstance(cfg.paints, (list, tuple))
    colors = choose_paints(resize(photo, LAYER_SIZE), cfg.paints, cfg.seed) if chosen else parse_paints(cfg.paints)
    paints = Paints(brush, in_order(colors, cfg.paint_order))
    with ProgressBar(cfg.paint_steps, cfg.progress, "layer steps") as bar:
        strokes, paints = lay(paints, strokes, resize(photo, cfg.work_size), cfg.background, cfg.paint_steps, tune=chosen,
                              trainable=covering(brush) if cfg.opaque else None,
                              tick=lambda: bar.advance(1, "laying the paints"))
    log.info(f"paints, in the order they are laid ({cfg.paint_order}): {' '.join(paints.hex())}")
    return strokes, paints, bar.seconds


def paint(cfg: PaintConfig, photo: torch.Tensor | None = None, brush_named: bool = True,
          callbacks: Sequence[Callback] = ()) -> dict:
    """Paint ``cfg.image`` (or ``photo``, as :func:`prepare` takes it); write the painting's files into
    ``cfg.output_dir``; return the metrics (``seconds``: the whole run, the checks and files included).
    ``callbacks`` hear the painter too (:class:`~nsp.painter.painter.Callback`; one raising
    KeyboardInterrupt stops it as Ctrl-C does).
    Unless ``brush_named``, a trained renderer paints with its checkpoint's brush (:func:`follows_checkpoint`).
    Interrupted (Ctrl-C, SIGTERM) or failing part-way, it still writes ``strokes.json`` and
    ``final.png`` of what was painted (no stroke yet: the bare canvas), then re-raises."""
    start = time.perf_counter()
    if follows_checkpoint(cfg, brush_named):
        cfg.brush.name = checkpoint_brush(cfg.renderer.checkpoint)
    painter, photo, image, style = prepare(cfg, photo)
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    target = resize(photo, cfg.work_size)
    brush, background = painter.brush, cfg.background  # styled strokes may come with a background of their own
    phases = []  # what took how long, as the bars showed it
    with SummaryWriter(out) as writer:  # events in the run dir: TensorBoard names the run after it
        board = TensorBoard(writer, target)
        with ProgressBar(cfg.strokes, cfg.progress) as bar:  # the painting's time: its face search too
            painter.callbacks += [board, bar, *callbacks]
            try:
                faces = find_faces(target) if round(cfg.schedule.face_share * cfg.strokes) > 0 else []
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
                strokes, background, seconds = paint_style(cfg, painter, strokes, photo, image, style, writer)
                phases.append(f"styled in {seconds:.1f} s")
            if cfg.paints is not None:
                strokes, paints, laying = paint_layers(cfg, brush, strokes, photo)
                phases.append(f"laid in {counted(len(paints), 'paint')} in {laying:.1f} s")
            frames = len(frame_ends(len(strokes), cfg.animation_frames))
            log.info(f"writing final.png, strokes.json, painting.svg, animation.gif ({frames} frames)…")
            files = time.perf_counter()
            scores = write_files(out, strokes, brush, photo, background, cfg.render_size, cfg.animation_size,
                                 cfg.animation_frames, workers=min(3, torch.get_num_threads()),
                                 compile=cfg.renderer.compile, paints=None if cfg.paints is None else paints.hex())
        except BaseException:
            with shielded():
                write_strokes_and_png(out, strokes, brush, photo.shape[-2:], background, cfg.render_size)  # styled, if it was
            raise
        phases.append(f"wrote the files in {time.perf_counter() - files:.1f} s")
        board.log_run(settings(cfg), scores)
    laid = {} if cfg.paints is None else {"paints": paints.hex(), "laying_seconds": round(laying, 2)}
    metrics = scores | laid | {"seconds": round(time.perf_counter() - start, 2), "painting_seconds": round(painting, 2),
                        "strokes": len(strokes), "faces": len(faces), "threads": torch.get_num_threads()}
    write_json(out / "metrics.json", metrics)
    log.info(f"{', '.join(phases)}: PSNR {scores['psnr']:.2f} dB, SSIM {scores['ssim']:.3f}; {out}")
    return metrics
