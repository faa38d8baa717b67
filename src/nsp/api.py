"""nsp from Python: :func:`paint`, :func:`load` and :func:`train`, with the commands' configs (their
defaults and checks come from the same YAML and schemas), without a Hydra app::

    import nsp
    painting = nsp.paint("photo.jpg", brush="watercolor", strokes=500)  # or a PIL image, array, tensor
    painting.render(2048)          # (H, W, 3) uint8 at any size
    painting.save("out/")          # final.png, strokes.json, painting.svg, animation.gif, metrics.json
    nsp.load("out/strokes.json").render(4096)

Keywords are the commands' keys: a config group's option (``brush="tape"``, ``renderer="neural"``), a
value (``strokes=200``), a nested one by its dotted name or as a dict (``style={"image": "s.jpg"}``).
"""
from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from hydra.errors import MissingConfigException
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from nsp.cli import did_you_mean
from nsp.config import CONF
from nsp.engine import paint_canvas
from nsp.errors import BadInput
from nsp.io.strokes import StrokeFile, load_strokes

FILES = ("final.png", "strokes.json", "painting.svg", "animation.gif", "metrics.json", "style.png")


@dataclass
class Painting:
    """A painting: its strokes (:class:`~nsp.io.strokes.StrokeFile`), the folder of its files and its
    metrics (empty for a painting interrupted, or loaded without its ``metrics.json``)."""

    strokes: StrokeFile
    folder: Path
    metrics: dict

    def render(self, size: int = 1024) -> np.ndarray:
        """The painting drawn by the vector engine, long side ``size``: (H, W, 3) uint8."""
        height, width = self.strokes.size(size)
        with torch.no_grad():
            image = paint_canvas(self.strokes.brush, self.strokes.strokes, height, width, self.strokes.background)
        return (image.permute(1, 2, 0) * 255).round().byte().numpy()

    def save(self, folder: str | Path) -> Path:
        """Copy the painting's files into ``folder`` (made if absent); returns it."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        for name in FILES:
            if (self.folder / name).is_file():
                shutil.copy2(self.folder / name, folder / name)
        return folder


def paint(image: Any, *, out: str | Path | None = None, **options: Any) -> Painting:
    """Paint ``image`` (a path or built-in photo's name, a PIL image, an (H, W, 3) array or a (3, H, W)
    tensor in [0, 1]) as ``python -m nsp.paint`` does, with ``options`` as its keys; the files go into
    ``out`` (default: a new temporary folder). Ctrl-C returns what was painted so far."""
    from nsp.painter.run import paint as run

    photo = None if isinstance(image, (str, Path)) else _tensor(image)
    cfg = _config("paint", {"image": str(image) if photo is None else "array", **options}, out)
    try:
        metrics = run(cfg, photo, brush_named="brush" in options)
    except KeyboardInterrupt:
        metrics = {}
    return load(Path(cfg.output_dir) / "strokes.json", metrics)


def load(path: str | Path, metrics: dict | None = None) -> Painting:
    """A painting from its ``strokes.json`` (an nsp stroke file), with the ``metrics.json`` beside it."""
    path = Path(path)
    if metrics is None:
        beside = path.parent / "metrics.json"
        metrics = OmegaConf.to_container(OmegaConf.load(beside)) if beside.is_file() else {}
    return Painting(load_strokes(path), path.parent, metrics)


def train(*, out: str | Path | None = None, **options: Any) -> dict:
    """Train a renderer as ``python -m nsp.train`` does, ``options`` its keys (``renderer="dcgan"``,
    ``brush="tape"``, ``trainer={"max_steps": 100}``); files into ``out`` (default: a new temporary
    folder). Returns the run's metrics."""
    from nsp.training.run import train as run
    from nsp.training.schema import register_configs

    register_configs()
    return run(_config("train", options, out))


def _config(command: str, options: dict[str, Any], out: str | Path | None) -> DictConfig:
    """The command's config as its command line would compose it, with ``options``: a config group's
    option by name (an override), any other key merged on its schema (so it is typed and checked)."""
    if command == "paint":
        import nsp.painter.schema  # noqa: F401  (registers paint_schema)
    groups = {p.name for p in (CONF / command).iterdir() if p.is_dir() and p.name != "hydra"} | {"brush"}
    choices = [f"{key}={value}" for key, value in options.items() if key in groups and isinstance(value, str)]
    values: dict = {}
    for key, value in options.items():
        if not (key in groups and isinstance(value, str)):
            _nest(values, key, value)
    folder = Path(out) if out is not None else Path(tempfile.mkdtemp(prefix=f"nsp-{command}-"))
    try:
        with initialize_config_dir(str(CONF / command), version_base="1.3"):
            cfg = compose(command, overrides=choices, return_hydra_config=True)
    except MissingConfigException as error:  # brush="oil"
        group, _, option = (error.missing_cfg_file or "").rpartition("/")
        raise BadInput(f"{group}={option}: no such {group}; expected one of: {', '.join(error.options or [])}") from None
    HydraConfig.instance().set_config(cfg)  # as a Hydra app's run: the runtime choices name the run
    try:
        merged = OmegaConf.merge(cfg, values, {"output_dir": str(folder)})
    except OmegaConfBaseException as error:  # a key the schema lacks, a value of the wrong type: as the command says it
        key, first = getattr(error, "full_key", None), str(error).strip().splitlines()[0]
        raise BadInput((key and did_you_mean(f"Could not override '{key}'", cfg)) or (f"{key}: {first}" if key else first)) from None
    return OmegaConf.masked_copy(merged, [key for key in merged if key != "hydra"])


def _nest(tree: dict, key: str, value: Any) -> None:
    """``tree`` with ``value`` at the dotted ``key`` (``schedule.polish`` -> {"schedule": {"polish": …}})."""
    *parents, last = key.split(".")
    for part in parents:
        tree = tree.setdefault(part, {})
    tree[last] = value


def _tensor(image: Any) -> torch.Tensor:
    """A PIL image, an (H, W, 3|4) or (H, W) array (uint8, or floats in [0, 1]), or a (3, H, W) tensor
    as (3, H, W) float in [0, 1]."""
    if isinstance(image, torch.Tensor):
        photo = image.detach().float().cpu()
    else:
        array = np.asarray(image.convert("RGB") if hasattr(image, "convert") else image)
        array = np.repeat(array[..., None], 3, -1) if array.ndim == 2 else array[..., :3]
        photo = torch.from_numpy(array.astype(np.float32) / (255 if array.dtype == np.uint8 else 1)).permute(2, 0, 1)
    if photo.ndim != 3 or photo.shape[0] != 3 or not torch.isfinite(photo).all():
        raise BadInput(f"image: expected an RGB picture (3, H, W) or (H, W, 3) of finite values, got shape {tuple(photo.shape)}")
    return photo.clamp(0, 1).contiguous()
