"""The transportation-loss studies (paper §3.4, §4.3), as painting experiments, L1 vs L1 + OT:
:func:`push` (Figs. 4, 5), a stroke that starts beside its target, where a pixel loss gives its position
no gradient and the transport cost pulls it over; :func:`digits` (Fig. 8), scikit-learn's 8×8 digits
upsampled, each painted with a few marker-pen strokes from the same random start.

Each is ``task(cfg, **arguments) -> metrics`` on ``nsp.paint``'s config (``brush``, ``work_size`` the
square canvas side, ``renderer``, ``loss``, ``optimizer``, ``seed``, ``strokes``, ``output_dir``);
``conf/paint/experiment/ot_*.yaml`` choose the task and its arguments.
"""
from __future__ import annotations

import itertools
import time
from pathlib import Path

import torch
import torch.nn.functional as F
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from torch import Tensor
from torch.utils.tensorboard import SummaryWriter
from torchvision.utils import make_grid

from nsp.brushes import Brush, get_brush
from nsp.colors import parse_color
from nsp.engine.device import resolve_device
from nsp.engine import composite, paint_canvas, render
from nsp.errors import BadInput
from nsp.files import write_json
from nsp.images import psnr
from nsp.io.export import write_png
from nsp.painter.losses import PaintLoss
from nsp.painter.optimize import optimize_strokes
from nsp.painter.renderer import build_renderer

ON_TARGET = 0.05  # a pushed stroke whose centre ends this close to its target's (canvas widths) converged


def setup(cfg: DictConfig) -> tuple[Brush, object, PaintLoss, Tensor, torch.device]:
    """The brush, the painter's renderer (on the device) and loss, the blank canvas colour (3,) and
    the device of ``cfg``. The seeded strokes and targets are drawn on the CPU, then moved there."""
    brush, device = get_brush(cfg.brush.name, cfg.brush.texture), resolve_device(cfg.device)
    background = parse_color(cfg.background)
    loss = PaintLoss.from_config(OmegaConf.to_object(cfg.loss), background)
    return brush, build_renderer(OmegaConf.to_object(cfg.renderer), brush, device), loss, torch.tensor(background), device


def centre(alpha: Tensor) -> Tensor:
    """(B, 1, H, W) coverage -> (B, 2) its centre of mass (x, y), in canvas units (pixel p at p/(W−1))."""
    height, width = alpha.shape[-2:]
    ys, xs = torch.linspace(0, 1, height)[:, None], torch.linspace(0, 1, width)[None, :]
    mass = alpha[:, 0].sum((-2, -1)).clamp_min(1e-8)  # a vanished stroke sits at (0, 0) rather than NaN
    return torch.stack([(alpha[:, 0] * xs).sum((-2, -1)) / mass, (alpha[:, 0] * ys).sum((-2, -1)) / mass], -1)


def position_error(brush: Brush, x: Tensor, goal: Tensor, side: int) -> Tensor:
    """(B,) distance between the centres of strokes x (B, d) and goal (B, d), as the engine draws them."""
    return (centre(render(brush, x, side)[1]) - centre(render(brush, goal, side)[1])).norm(dim=-1)


def shift(brush: Brush, x: Tensor, offset: Tensor) -> Tensor:
    """Strokes x (B, d) moved by offset (B, 2) (canvas units): every x-kind and y-kind parameter."""
    moved = x.clone()
    for index, kind in enumerate(brush.kinds):
        if kind in ("x", "y"):
            moved[:, index] += offset[:, 0 if kind == "x" else 1]
    return moved


def push_pairs(brush: Brush, trials: int, side: int, gap: float, size: tuple[float, float], background: Tensor,
               generator: torch.Generator) -> tuple[Tensor, Tensor]:
    """``trials`` (target, start) stroke pairs (trials, d) each, the start the target moved ``gap`` canvas
    widths in a random direction, inside the canvas and not overlapping it. Sizes lie in ``size`` (fractions
    of the canvas), alpha is 1, and colours lie at least halfway from the canvas colour ``background`` (3,)
    to its opposite, so every stroke carries transport mass."""
    sizes = [i for i, kind in enumerate(brush.kinds) if kind == "size"]
    positions = [i for i, kind in enumerate(brush.kinds) if kind in ("x", "y")]
    colors, channel = list(brush.color), background.repeat(len(brush.color) // 3)  # each colour parameter's channel
    targets, starts = [], []
    while len(targets) < trials:
        x = brush.sample(64, generator=generator)
        x[:, sizes] = size[0] + (size[1] - size[0]) * x[:, sizes]
        x[:, colors] = channel + (1 - 2 * channel) * (0.5 + 0.5 * x[:, colors])
        x[:, [i for i, kind in enumerate(brush.kinds) if kind == "alpha"]] = 1.0
        angle = 2 * torch.pi * torch.rand(64, generator=generator)
        start = shift(brush, x, gap * torch.stack([angle.cos(), angle.sin()], -1))
        inside = ((start[:, positions] > 0.05) & (start[:, positions] < 0.95)).all(-1)
        overlap = (render(brush, x, side)[1] * render(brush, start.clamp(0, 1), side)[1]).sum((1, 2, 3))
        for keep in torch.nonzero(inside & (overlap == 0)).flatten().tolist():
            targets.append(x[keep])
            starts.append(start[keep])
    return torch.stack(targets[:trials]), torch.stack(starts[:trials])


def optimize(out: Path, steps: int, x: Tensor, loss: PaintLoss, optimizer, draw, target: Tensor,
             watch=None, every: int = 10) -> list[Tensor]:
    """Optimize strokes x (requires grad) for ``steps`` steps so ``draw(x)`` (B, 3, s, s) matches target,
    logging to TensorBoard under ``out`` the loss terms per step and ``watch(x) -> {name: value}`` every
    ``every`` steps; returns the canvases at steps 0, ¼, ½, ¾ and the end (for the figures)."""
    marks = {round(steps * f) for f in (0, 0.25, 0.5, 0.75, 1)}
    frames, counter = [], itertools.count()
    with SummaryWriter(out) as writer:  # events in the run dir: TensorBoard names the run after it
        def observe(canvas: Tensor) -> None:
            step = next(counter)
            if step in marks:
                frames.append(canvas.detach())
            if watch is not None and (step % every == 0 or step == steps):
                for name, value in watch(x.detach()).items():
                    writer.add_scalar(name, value, step)

        def objective() -> tuple[Tensor, dict[str, Tensor]]:
            canvas = draw(x)
            observe(canvas)
            return canvas, loss(canvas, target)

        for step, (_, losses) in enumerate(optimize_strokes(x, optimizer, steps, objective)):
            for name, value in losses.items():
                writer.add_scalar(f"loss/{name}", value, step)  # the loss of the canvas at ``step``
        with torch.no_grad():
            observe(draw(x))
    return frames


def push(cfg: DictConfig, trials: int = 8, steps: int = 150, gap: float = 0.45,
         size: tuple[float, float] = (0.15, 0.25)) -> dict:
    """Push strokes onto targets they start beside (paper Figs. 4, 5); ``trials`` independent pairs at once.
    Writes ``push.png`` (a row per trial, four at most: target, then the canvas at steps 0, ¼, ½, ¾, end),
    TensorBoard curves (``loss/*``, ``position_error``) and ``metrics.json``: ``position_error`` (mean final
    distance of the stroke's centre from its target's, canvas widths), ``position_error_start``,
    ``converged`` (fraction ending within 0.05), ``psnr``, ``seconds``."""
    start_time = time.perf_counter()
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    brush, renderer, loss, background, device = setup(cfg)
    side = renderer.resolution(cfg.work_size)
    generator = torch.Generator().manual_seed(cfg.seed)
    goal, start = push_pairs(brush, trials, side, gap, tuple(size), background, generator)
    goal, start, background = goal.to(device), start.to(device), background.to(device)
    blank = background[:, None, None].expand(trials, 3, side, side)

    def over(fg: Tensor, alpha: Tensor) -> Tensor:
        return alpha * fg + (1 - alpha) * blank

    target = over(*render(brush, goal, side))  # drawn by the engine, as a photo would be
    x = start.clone().requires_grad_(True)
    frames = optimize(out, steps, x, loss, instantiate(cfg.optimizer)([x]), lambda x: over(*renderer(x, side)), target,
                      watch=lambda x: {"position_error": float(position_error(brush, x, goal, side).mean())})
    shown = min(trials, 4)
    rows = torch.stack([target[:shown], *(frame[:shown] for frame in frames)], 1).flatten(0, 1)
    write_png(out / "push.png", make_grid(rows.clamp(0, 1), nrow=len(frames) + 1, padding=2, pad_value=0.5))

    error = position_error(brush, x.detach(), goal, side)
    metrics = {
        "position_error": round(float(error.mean()), 4),
        "position_error_start": round(float(position_error(brush, start, goal, side).mean()), 4),
        "converged": round(float((error < ON_TARGET).float().mean()), 3),
        "psnr": round(float(psnr(over(*render(brush, x.detach(), side)), target).mean()), 3),
        "seconds": round(time.perf_counter() - start_time, 2),
        "strokes": trials,
    }
    write_json(out / "metrics.json", metrics)
    return metrics


def digit_targets(count: int, side: int, background: Tensor) -> tuple[Tensor, Tensor]:
    """The first ``count`` of scikit-learn's digits at side×side: ink masks (count, 1, side, side) in
    [0, 1] and targets (count, 3, side, side), ink in the canvas colour's opposite."""
    from sklearn.datasets import load_digits  # imported here: slow, and only this task needs it

    images = torch.from_numpy(load_digits().images[:count]).float()[:, None] / 16
    mask = F.interpolate(images, size=(side, side), mode="bilinear", align_corners=False).clamp(0, 1)
    ink = 1 - background
    return mask, background[:, None, None] * (1 - mask) + ink[:, None, None] * mask


def off_ink_starts(brush: Brush, mask: Tensor, k: int, length: float, size: tuple[float, float], gap: float,
                   generator: torch.Generator) -> Tensor:
    """``k`` short, thin Bézier strokes per digit (count·k, d), P0 and P2 ``length`` apart, P1 halfway, each
    centred at least ``gap`` canvas widths (plus its reach) from any ink of its digit in ``mask``
    (count, 1, s, s) in [0, 1], so that none overlaps its target at the start."""
    if brush.kinds[:6] != ("x", "y") * 3:
        raise BadInput(f"ot_digits draws Bézier strokes; brush={brush.name} is not one (use markerpen or watercolor)")
    count, side = mask.shape[0], mask.shape[-1]
    reach = round((gap + length) * side)
    near_ink = F.max_pool2d((mask > 0.05).float(), 2 * reach + 1, stride=1, padding=reach)[:, 0] > 0
    x = brush.sample(count * k, generator=generator)
    for digit in range(count):
        free = torch.nonzero(~near_ink[digit]).float() / (side - 1)  # (n, 2) as (y, x)
        if len(free) == 0:
            raise BadInput(f"digit {digit} leaves no canvas {gap} away from its ink; lower task.gap")
        pick = free[torch.randint(len(free), (k,), generator=generator)]
        angle = torch.pi * torch.rand(k, generator=generator)
        half = 0.5 * length * torch.stack([angle.cos(), angle.sin()], -1)  # (k, 2) as (x, y)
        centre = pick.flip(-1)
        rows = slice(digit * k, (digit + 1) * k)
        x[rows, 0:2], x[rows, 2:4], x[rows, 4:6] = centre - half, centre, centre + half  # a straight segment
    thickness = [i for i, kind in enumerate(brush.kinds) if kind == "size"]
    x[:, thickness] = size[0] + (size[1] - size[0]) * x[:, thickness]
    return x.clamp(0, 1)


def digits(cfg: DictConfig, count: int = 50, steps: int = 300, length: float = 0.08,
           init_size: tuple[float, float] = (0.1, 0.2), gap: float = 0.05) -> dict:
    """Paint ``count`` digits with ``cfg.strokes`` marker-pen strokes each (paper Fig. 8), from the same
    seeded strokes whatever the loss: short, thin, opaque, in the ink's colour and away from the digit's
    ink (``off_ink_starts``), where a pixel loss gives them no gradient; all parameters are optimized.

    Writes ``digits.png`` (first ten digits; rows: target, start, painting by the engine), ``digits.json``
    (per-digit PSNR and IoU), TensorBoard curves and ``metrics.json``: ``psnr``, ``iou`` (means over digits;
    IoU of the painted and target ink, each thresholded at half ink), ``psnr_std``, ``iou_std``, the start's
    ``iou_start`` (0: no overlap), ``seconds``, ``strokes``.
    """
    start_time = time.perf_counter()
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    brush, renderer, loss, background, device = setup(cfg)
    side = renderer.resolution(cfg.work_size)
    mask, target = digit_targets(count, side, background)
    k = cfg.strokes
    x0 = off_ink_starts(brush, mask, k, length, tuple(init_size), gap, torch.Generator().manual_seed(cfg.seed))
    x0[:, [i for i, kind in enumerate(brush.kinds) if kind == "alpha"]] = 1.0
    ink = list(brush.color)
    x0[:, ink] = (1 - background).repeat(len(ink) // 3)
    mask, target, x0, background = mask.to(device), target.to(device), x0.to(device), background.to(device)
    blank = background[:, None, None].expand(count, 3, side, side)

    def draw(x: Tensor) -> Tensor:
        fg, alpha = renderer(x, side)
        return composite(fg.view(count, k, 3, side, side), alpha.view(count, k, 1, side, side), blank)

    def engine(x: Tensor) -> Tensor:
        with torch.no_grad():
            return torch.stack([paint_canvas(brush, s, side, side, cfg.background) for s in x.view(count, k, -1)])

    def ink_iou(painted: Tensor) -> Tensor:
        inked = (painted - blank).abs().mean(1) / (1 - 2 * background).abs().mean().clamp_min(1e-3) > 0.5
        truth = mask[:, 0] > 0.5
        return (inked & truth).sum((1, 2)) / (inked | truth).sum((1, 2)).clamp_min(1)

    x = x0.clone().requires_grad_(True)
    optimize(out, steps, x, loss, instantiate(cfg.optimizer)([x]), draw, target)
    start, painted = engine(x0), engine(x.detach())
    scores, iou = psnr(painted, target), ink_iou(painted)
    shown = min(count, 10)
    write_png(out / "digits.png", make_grid(torch.cat([target[:shown], start[:shown], painted[:shown]]).clamp(0, 1),
                                            nrow=shown, padding=2, pad_value=0.5))
    write_json(out / "digits.json", {"psnr": scores.tolist(), "iou": iou.tolist()})
    metrics = {
        "psnr": round(float(scores.mean()), 3),
        "psnr_std": round(float(scores.std()), 3),
        "iou": round(float(iou.mean()), 4),
        "iou_std": round(float(iou.std()), 4),
        "iou_start": round(float(ink_iou(start).mean()), 4),
        "seconds": round(time.perf_counter() - start_time, 2),
        "strokes": k,
    }
    write_json(out / "metrics.json", metrics)
    return metrics
