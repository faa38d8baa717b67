"""Config schemas shared by the entry points, registered in Hydra's ConfigStore, the names the
configs choose from, and the resolvers of the studies' configs (a per-size key, a training sweep's
checkpoints for a painting sweep).

The ``brush`` group is generated from :data:`BRUSH_NAMES`, so a new brush needs no YAML and a
misspelt ``brush=`` fails at compose time listing the valid brushes. Nothing here imports torch:
the commands' ``--help`` reads it.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from hydra.core.config_store import ConfigStore
from omegaconf import OmegaConf

from nsp.errors import BadInput

CONF = Path(__file__).parent / "conf"  # each command's YAML: conf/paint, conf/train, conf/render (in a checkout, a link to the top-level conf/)


BRUSH_NAMES = ("oilpaint", "watercolor", "markerpen", "tape")  # nsp.brushes.BRUSHES' keys (a test holds them equal)
BACKBONES = ("auto", "vgg19", "random")  # style.backbone: the feature networks of nsp.style.features (auto: vgg19 where its weights are)
MODES = ("full", "color")  # style.mode: what style transfer changes (nsp.painter.stylize)
PAINT_ORDERS = ("light_to_dark", "dark_to_light", "listed")  # paint_order: the layers' order (nsp.painter.paints.in_order)
MAX_PAINTS = 32


def check_paints(paints) -> None:
    """``paints``: K (2–:data:`MAX_PAINTS`) or a list of 1–32 colours (``#rrggbb``, black, white);
    :class:`BadInput` naming the value otherwise. No torch: the schema checks it."""
    if isinstance(paints, (list, tuple)):
        if not 1 <= len(paints) <= MAX_PAINTS:
            raise BadInput(f"paints={list(paints)}: expected 1 to {MAX_PAINTS} colours #rrggbb")
        for paint in paints:
            if not (str(paint).lower() in ("black", "white") or re.fullmatch(r"#[0-9a-fA-F]{6}", str(paint).strip())):
                raise BadInput(f"paints: {paint} is not a colour; expected #rrggbb (or black, white)")
    elif isinstance(paints, bool) or not isinstance(paints, int) or not 2 <= paints <= MAX_PAINTS:
        raise BadInput(f"paints={paints}: expected a number of paints from 2 to {MAX_PAINTS}, or a list of colours "
                       "[#rrggbb, …]")


@dataclass
class BrushConfig:
    name: str
    texture: Optional[str] = None  # grayscale image for oilpaint's bristles; None = nsp's own
    impasto: bool = True  # oilpaint: its paint's relief lit from the upper left
    glaze: Optional[float] = None  # watercolor, markerpen: 0 covers, 1 multiplies (overlaps darken); None: the brush's


@dataclass
class PlotConfig:
    """``nsp.render``'s ``plot.*``: how a painting laid in paints becomes a machine's file (nsp.io.machine)."""

    page: str = "a4"  # vpype's page formats (a4, a3, letter, …) or WxH with a unit (30x40cm)
    margin: str = "10mm"  # kept clear on every side
    pen: str = "0.5mm"  # the line a pen (or brush) draws: a wider stroke takes several passes
    refill: Optional[str] = None  # G-code: a pause for paint every N strokes (20) or length of line (2m); None: per paint
    device: str = "hp7475a"  # HPGL: the plotter, as vpype knows it (its pens: one a paint, cycling past its count)


def compile_choice(value: bool | str | None, key: str) -> bool | None:
    """A ``compile`` option (``true``, ``false`` or ``auto``) as the engine takes it: True, False, or None
    for auto (:func:`nsp.engine.fused.choose`); :class:`BadInput` naming ``key`` for any other value."""
    if value is None or value == "auto":
        return None
    if isinstance(value, bool):
        return value
    raise BadInput(f"{key}={value}: expected true, false or auto")


for name in BRUSH_NAMES:
    ConfigStore.instance().store(group="brush", name=name, node=BrushConfig(name=name))


ANALYTIC = "analytic:"  # experiment=renderer_painting's swept renderer that is the analytic one: analytic:BRUSH[:SEED]


def trained_renderers(sweep: str) -> str:
    """``${trained_renderers:DIR}``: every completed job's ``checkpoints/last.ckpt`` (the model its test
    PSNR scores) in the training sweep ``DIR``, then ``analytic:BRUSH:SEED`` per brush and training seed
    (the analytic renderer paints with as many painter seeds as the networks were trained with), as quoted
    sweep values."""
    jobs = trained_jobs(sweep)
    runs = dict.fromkeys((job_metrics(job)["brush"], job_metrics(job).get("seed", 0)) for job in jobs)
    values = [str(job / "checkpoints" / "last.ckpt") for job in jobs] + [f"{ANALYTIC}{brush}:{seed}" for brush, seed in runs]
    if bad := [value for value in values if "'" in value or "\\" in value]:
        raise BadInput(f"task.sweep={sweep}: {bad[0]} has a quote or backslash in its path; move the sweep elsewhere")
    return ",".join(f"'{value}'" for value in values)


def trained_jobs(sweep: str) -> list[Path]:
    """The run dirs of the training sweep ``sweep`` that completed with ``checkpoints/last.ckpt``;
    :class:`BadInput` where there is none."""
    jobs = sorted(path.parent.parent for path in Path(sweep).glob("*/checkpoints/last.ckpt")
                  if job_metrics(path.parent.parent).get("status") == "completed")
    if not jobs:
        raise BadInput(f"task.sweep={sweep} holds no completed training job with checkpoints/last.ckpt; give the dir "
                       "of a finished `python -m nsp.train -m experiment=renderer_comparison` (or renderer_ablation)")
    return jobs


def job_metrics(job: Path) -> dict:
    """A run dir's ``metrics.json``; {} where it has none, or none that reads as an object."""
    try:
        metrics = json.loads((job / "metrics.json").read_text())
    except (OSError, ValueError):
        return {}
    return metrics if isinstance(metrics, dict) else {}


def renderer_label(renderer: str) -> str:
    """``${renderer_label:RENDERER}``: a swept renderer as a dir name, its training job's dir's
    (``3_dcgan_watercolor_seed0``) or ``analytic_BRUSH_seedSEED``, so it stays the same as its sweep grows."""
    if renderer.startswith(ANALYTIC):
        brush, _, seed = renderer[len(ANALYTIC):].partition(":")
        return f"analytic_{brush}" + (f"_seed{seed}" if seed else "")
    return Path(renderer).parents[1].name


# ${px:SIZE}: a size as the key of a per-size table (32px; OmegaConf keys are text)
OmegaConf.register_new_resolver("px", lambda size: f"{size}px", replace=True)
# ${image_name:IMAGE}: a photo as part of a dir name: a built-in photo's name, a file's stem
OmegaConf.register_new_resolver("image_name", lambda image: Path(image).stem, replace=True)
OmegaConf.register_new_resolver("trained_renderers", trained_renderers, replace=True)
OmegaConf.register_new_resolver("renderer_label", renderer_label, replace=True)
