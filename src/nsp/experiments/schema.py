"""``nsp.paint``'s schema plus ``task``: the procedure a painting experiment runs instead of painting
``image=`` (``conf/paint/experiment/ot_*.yaml``)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hydra.core.config_store import ConfigStore

from nsp.painter.schema import PaintConfig


@dataclass
class ExperimentConfig(PaintConfig):
    task: Any = None  # a ``_partial_`` callable, cfg -> metrics, e.g. nsp.experiments.ot.push


def register() -> None:
    """Replace ``paint_schema`` by :class:`ExperimentConfig` in Hydra's ConfigStore."""
    ConfigStore.instance().store(name="paint_schema", node=ExperimentConfig)
