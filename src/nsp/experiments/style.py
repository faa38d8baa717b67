"""The style-transfer study (paper §3.5) as a painting experiment: each photo is painted once, then
stylized toward each style image in each mode, and every result is measured
(:mod:`nsp.style.measures`) against its plain painting, its photo and its style.

``grid(cfg, photos, styles, modes) -> metrics`` runs on ``nsp.paint``'s config (``style.size`` is the
canvas of the style steps and of every measure); ``conf/paint/experiment/style_grid.yaml`` chooses
the images, ``style_heldout.yaml`` the held-out pairs of colour mode (docs/style.md).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from torch import Tensor
from torchvision.utils import make_grid

from nsp.engine import paint_canvas
from nsp.errors import BadInput
from nsp.files import write_json
from nsp.images import BUILTIN, load_image, resize
from nsp.io.export import write_png
from nsp.painting.callbacks import ProgressBar
from nsp.painter.painter import Painter
from nsp.painting.run import prepare
from nsp.painting.schema import paint_settings
from nsp.config import MODES
from nsp.painter.stylize import stylize
from nsp.style import StyleLoss
from nsp.style.recolor import ColorSettings
from nsp.style.measures import coherence, color_distance, luminance_ssim, texture_distance

TARGETS = {"color_distance_drop": 0.5, "coherence": 0.05, "ssim_ratio": 0.9}  # colour mode: ≥, ≤, ≥
COLUMNS = ("color_distance", "color_distance_drop", "coherence", "luminance_ssim", "ssim_ratio", "style_loss",
           "texture_distance")


def style_image(name: str, size: int) -> Tensor:
    """A photo of ``nsp.images.BUILTIN`` or any image of ``skimage.data`` (grey ones, such as brick and
    gravel, as three equal channels), long side ``size``, as RGB (3, h, w) in [0, 1]."""
    return resize(load_image(name, max_side=size) if name in BUILTIN else skimage_image(name), size)


def skimage_image(name: str) -> Tensor:
    """The image ``skimage.data.<name>()`` (the first of a stereo pair) as RGB (3, H, W) in [0, 1]."""
    import skimage.data

    loader = getattr(skimage.data, name, None)
    if name.startswith("_") or not callable(loader):
        raise ValueError(f"image {name}: expected one of {', '.join(BUILTIN)} or an image of skimage.data")
    array = loader()
    array = np.asarray(array[0] if isinstance(array, tuple) else array)
    image = torch.from_numpy(array.astype(np.float32) / (255 if array.dtype == np.uint8 else 1))
    return image.expand(3, -1, -1).contiguous() if image.ndim == 2 else image[..., :3].permute(2, 0, 1).contiguous()


def photo_spec(name: str, folder: Path) -> str:
    """What ``image=`` paints ``name`` as: a built-in photo's name, or a PNG of it written into ``folder``."""
    if name in BUILTIN:
        return name
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.png"
    write_png(path, skimage_image(name))
    return str(path)


def measure(image: Tensor, plain: Tensor, photo: Tensor, style: Tensor, loss: StyleLoss) -> dict[str, float]:
    """The measures of one painting ``image`` (3, H, W) of ``photo`` against its ``plain`` painting
    and its ``style`` image; ``style_loss`` is the style steps' own (``loss``)."""
    with torch.no_grad():
        style_loss = float(loss(image))
    return {"color_distance": color_distance(image, style), "coherence": coherence(plain, image),
            "luminance_ssim": luminance_ssim(image, photo), "style_loss": style_loss,
            "texture_distance": texture_distance(image, style)}


def meets_targets(row: dict) -> bool:
    """Whether the colour-mode measures ``row`` meet all three :data:`TARGETS`."""
    return (row["color_distance_drop"] >= TARGETS["color_distance_drop"] and row["coherence"] <= TARGETS["coherence"]
            and row["ssim_ratio"] >= TARGETS["ssim_ratio"])


def grid(cfg: DictConfig, photos: tuple[str, ...] = ("chelsea", "coffee", "flower"),
         styles: tuple[str, ...] = ("gravel", "brick", "rocket"), modes: tuple[str, ...] = MODES,
         color: dict | None = None) -> dict:
    """Paint every photo, stylize it toward every other image of ``styles`` (names of
    :func:`style_image`) in each of ``modes``, measure all. ``color``: colour mode's settings other
    than the defaults (:class:`~nsp.style.recolor.ColorSettings` fields).

    Writes ``pairs.json`` (per photo, style and mode, ``plain`` too, the measures, with
    ``color_distance_drop`` = 1 − distance / the plain painting's and ``ssim_ratio`` = luminance
    SSIM / the plain painting's), ``table.md``, ``grid.png`` (a row per pair: photo, style, plain,
    then each of ``modes``) and ``metrics.json`` (:func:`summary`, and ``seconds``).
    """
    if unknown := set(modes) - set(MODES):
        raise BadInput(f"task.modes: {', '.join(sorted(unknown))} unknown; expected some of {', '.join(MODES)}")
    try:
        settings = ColorSettings(**(color or {}))
    except TypeError as error:
        raise BadInput(f"task.color={color}: {error}; expected fields of nsp.style.recolor.ColorSettings") from None
    start = time.perf_counter()
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows, tiles = [], []
    with ProgressBar(sum(style != photo for photo in photos for style in styles), cfg.progress, "pairs") as bar:
        for photo_name in photos:
            bar.advance(0, f"painting {photo_name}")
            painter, photo, _, _ = prepare(paint_settings(OmegaConf.merge(
                cfg, {"image": photo_spec(photo_name, out / "photos"), "style": {"image": None}})))
            strokes = painter.paint(resize(photo, cfg.work_size), cfg.strokes)
            photo = resize(photo, cfg.style.size)
            for style_name in (s for s in styles if s != photo_name):
                bar.advance(0, f"{photo_name} × {style_name}")
                pair, paintings = pair_rows(cfg, painter, strokes, photo, style_name, modes, settings)
                rows += [{"photo": photo_name, "style": style_name, "mode": mode} | row for mode, row in pair.items()]
                tiles += [tile(x, cfg.style.size) for x in paintings]
                bar.advance(1, f"{photo_name} × {style_name}")
    write_json(out / "pairs.json", {"pairs": rows})
    (out / "table.md").write_text(table(rows))
    write_png(out / "grid.png", make_grid(torch.stack(tiles).clamp(0, 1), nrow=3 + len(modes), padding=2, pad_value=0.5))
    metrics = summary(rows) | {"seconds": round(time.perf_counter() - start, 2), "strokes": cfg.strokes}
    write_json(out / "metrics.json", metrics)
    return metrics


def pair_rows(cfg: DictConfig, painter: Painter, strokes: Tensor, photo: Tensor, style_name: str,
              modes: tuple[str, ...], settings: ColorSettings) -> tuple[dict[str, dict], list[Tensor]]:
    """The measures of the painting ``strokes`` (N, d) of ``photo`` (3, H, W) and of it stylized toward
    ``style_name`` in each of ``modes``, and the grid's row: photo, style, plain, then each mode's."""
    brush = painter.brush
    height, width = photo.shape[1:]
    image = style_image(style_name, cfg.style.size)
    style = StyleLoss(image[None], cfg.style.backbone, cfg.style.weights, cfg.seed)
    plain = paint_canvas(brush, strokes, height, width, cfg.background)
    paintings = {"plain": plain}
    for mode in modes:
        styled, canvas = stylize(
            brush, strokes, photo, image, painter.loss, instantiate(cfg.optimizer), loss=style,
            weight=cfg.style.weight, steps=cfg.style.steps, mode=mode, background=cfg.background,
            softness=cfg.renderer.softness, seed=cfg.seed, color=settings)
        paintings[mode] = paint_canvas(brush, styled, height, width, canvas)
    rows = {}
    for mode, painting in paintings.items():  # the plain painting first: the others' base
        row = rows[mode] = measure(painting, plain, photo, image, style)
        row["color_distance_drop"] = 1 - row["color_distance"] / rows["plain"]["color_distance"]
        row["ssim_ratio"] = row["luminance_ssim"] / rows["plain"]["luminance_ssim"]
    return rows, [photo, image, *paintings.values()]


def tile(image: Tensor, size: int) -> Tensor:
    """``image`` (3, h, w), long side ``size``, centred on a white size×size square (3, size, size)."""
    out = torch.ones(3, size, size)
    height, width = image.shape[1:]
    top, left = (size - height) // 2, (size - width) // 2
    out[:, top:top + height, left:left + width] = image
    return out


def summary(rows: list[dict]) -> dict:
    """Colour mode's worst case of each target measure (:data:`TARGETS`) and how many pairs meet all
    three; the mean texture distance of the plain paintings and of each mode's."""
    texture = {}
    for r in rows:
        texture.setdefault(r["mode"], []).append(r["texture_distance"])
    texture = {f"texture_distance_{mode}": round(sum(values) / len(values), 4) for mode, values in texture.items()}
    color = [r for r in rows if r["mode"] == "color"]
    if not color:
        return texture
    met = sum(meets_targets(r) for r in color)
    return {
        "color_distance_drop_min": round(min(r["color_distance_drop"] for r in color), 4),
        "coherence_max": round(max(r["coherence"] for r in color), 4),
        "ssim_ratio_min": round(min(r["ssim_ratio"] for r in color), 4),
        "pairs_meeting_targets": f"{met}/{len(color)}",
        "color_distance_drop_mean": round(sum(r["color_distance_drop"] for r in color) / len(color), 4),
    } | texture


def table(rows: list[dict]) -> str:
    """The measures as a Markdown table, a line per photo, style and mode."""
    head = ["photo", "style", "mode", *COLUMNS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["photo"], r["style"], r["mode"], *(f"{r[c]:.3f}" for c in COLUMNS)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
