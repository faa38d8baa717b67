"""Config schemas shared by the entry points, registered in Hydra's ConfigStore.

The ``brush`` group is generated from :data:`BRUSH_NAMES`, so a new brush needs no YAML and a
misspelt ``brush=`` fails at compose time listing the valid brushes. Nothing here imports torch:
the commands' ``--help`` reads it.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from hydra.core.config_store import ConfigStore
from omegaconf import OmegaConf

CONF = Path(__file__).parent / "conf"  # each command's YAML: conf/paint, conf/train, conf/render (in a checkout, a link to the top-level conf/)


BRUSH_NAMES = ("oilpaint", "watercolor", "markerpen", "tape")  # nsp.brushes.BRUSHES' keys (a test holds them equal)


@dataclass
class BrushConfig:
    name: str
    texture: Optional[str] = None  # grayscale image for oilpaint's bristles; None = nsp's own
    impasto: bool = True  # oilpaint: its paint's relief lit from the upper left


def register_brushes() -> None:
    cs = ConfigStore.instance()
    for name in BRUSH_NAMES:
        cs.store(group="brush", name=name, node=BrushConfig(name=name))


register_brushes()


def _trained_renderers(sweep: str) -> str:
    from nsp.experiments.renderers import trained_renderers  # light: no torch

    return trained_renderers(sweep)


# ${trained_renderers:DIR} in a sweep's params: the checkpoints of a training sweep (conf/paint/experiment/renderer_painting.yaml)
OmegaConf.register_new_resolver("trained_renderers", _trained_renderers, replace=True)
