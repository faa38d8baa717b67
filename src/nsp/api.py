"""nsp from Python: :func:`paint`, :func:`load` and :func:`train`, with the commands' configs (their
defaults and checks come from the same YAML and schemas), without a Hydra app::

    import nsp
    painting = nsp.paint("photo.jpg", brush="watercolor", strokes=500)  # or a PIL image, array, tensor
    painting.render(2048)          # (H, W, 3) uint8 at any size
    painting.save("out/")          # final.png, strokes.json, painting.svg, animation.gif, metrics.json
    painting                       # <Painting: 500 watercolor strokes, 1024×1024 px, PSNR … dB>; a notebook shows it
    nsp.load("out/strokes.json").render(4096)

Keywords are the commands' keys: a config group's option (``brush="tape"``, ``renderer="neural"``), a
value (``strokes=200``), a nested one by its dotted name or as a dict (``style={"image": "s.jpg"}``).
"""
from __future__ import annotations

import io
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import torch
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from hydra.errors import MissingConfigException
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException
from PIL import Image

from nsp.cli import REFUSED_WRITES, did_you_mean, refused_write, use_threads
from nsp.config import CONF
from nsp.engine import paint_canvas
from nsp.engine.memory import check_render, check_side
from nsp.errors import BadInput, RunFailed
from nsp.files import atomic_path
from nsp.images import BUILTIN, LAYOUTS, from_array, from_pil
from nsp.io.export import to_uint8
from nsp.io.strokes import StrokeFile, load_strokes, save_strokes
from nsp.text import shown

FILES = ("final.png", "strokes.json", "painting.svg", "animation.gif", "metrics.json", "style.png")
ACCEPTED = (f"a path, a built-in photo's name ({', '.join(BUILTIN)}), a PIL image, or a numpy array or torch "
            f"tensor shaped {LAYOUTS}")
PREVIEW = 512  # the long side of the picture a notebook shows


@dataclass
class Painting:
    """A painting: its strokes (:class:`~nsp.io.strokes.StrokeFile`), the folder of its files and its
    metrics (empty for a painting interrupted, or loaded without its ``metrics.json``)."""

    strokes: StrokeFile
    folder: Path
    metrics: dict

    def render(self, size: int = 1024) -> np.ndarray:
        """The painting drawn by the vector engine, long side ``size`` (≥ 16 pixels): (H, W, 3) uint8.
        A size past the memory there is raises :class:`BadInput` naming the largest that fits."""
        height, width = self.strokes.size(check_side(size))
        brush, strokes = self.strokes.brush, self.strokes.strokes
        check_render(brush, strokes, height, width)
        with torch.no_grad():
            return to_uint8(paint_canvas(brush, strokes, height, width, self.strokes.background))

    def save(self, folder: str | Path, *, overwrite: bool = False) -> Path:
        """Copy the painting's files into ``folder`` (made if absent), each whole; returns it. A folder
        holding another painting's files is refused (:class:`BadInput`) unless ``overwrite``: then it
        ends up holding this painting's files alone. A write the disk refuses raises :class:`RunFailed`."""
        folder = Path(folder)
        if folder.is_dir() and folder.resolve() == self.folder.resolve():
            return folder  # its own files
        _free(folder, "folder", overwrite)
        try:
            folder.mkdir(parents=True, exist_ok=True)
            for name in FILES:
                if (self.folder / name).is_file():
                    with atomic_path(folder / name) as temporary:
                        shutil.copy2(self.folder / name, temporary)
                elif name == "strokes.json":  # loaded from a file of another name, or its folder is gone
                    save_strokes(folder / name, self.strokes)
            for name in FILES:  # another painting's (its style.png), now the rest is this one's
                if not (self.folder / name).is_file() and name != "strokes.json":
                    (folder / name).unlink(missing_ok=True)
        except OSError as error:
            raise RunFailed(f"folder={folder}: could not save the painting there ({error.strerror or error}); "
                            "each file there is whole, the old one or the new") from None
        return folder

    def __repr__(self) -> str:
        """``<Painting: 500 oilpaint strokes, 1024×683 px, PSNR 22.31 dB>`` (no PSNR: not measured)."""
        psnr = self.metrics.get("psnr")
        score = f", PSNR {psnr:.2f} dB" if isinstance(psnr, (int, float)) else ""
        return (f"<Painting: {len(self.strokes.strokes)} {self.strokes.brush.name} strokes, "
                f"{self.strokes.width}×{self.strokes.height} px{score}>")

    def _repr_png_(self) -> bytes:
        """The painting as a notebook shows it: PNG bytes of a render of long side :data:`PREVIEW`."""
        buffer = io.BytesIO()
        Image.fromarray(self.render(PREVIEW)).save(buffer, format="PNG")
        return buffer.getvalue()


def paint(image: Any, *, out: str | Path | None = None, overwrite: bool = False, callbacks: Sequence = (),
          **options: Any) -> Painting:
    """Paint ``image`` as ``python -m nsp.paint`` does, with ``options`` as its keys; the files go into
    ``out`` (default: a new temporary folder). Ctrl-C returns what was painted so far (raised
    where nothing was yet).

    ``image``: a path or built-in photo's name, a PIL image, or a numpy array or torch tensor
    (:func:`nsp.images.from_array` reads its layout and values). A folder ``out`` holding another
    painting's files is refused unless ``overwrite``; then the files this painting lacks go when it
    is done. A bad value raises :class:`BadInput` (leaving no folder made for it), a write the disk
    refuses :class:`RunFailed` naming the files kept. ``callbacks`` (:class:`nsp.painter.painter.Callback`)
    hear each stroke, step and level; one that raises KeyboardInterrupt stops the painting as Ctrl-C does.
    """
    from nsp.painting.run import paint as run
    from nsp.painting.schema import paint_settings

    if out is not None:
        _free(Path(out), "out", overwrite)
    photo = None if isinstance(image, (str, os.PathLike)) else _photo(image)
    cfg = _config("paint", {"image": str(image) if photo is None else "array", **options}, out)
    folder = Path(cfg.output_dir)
    before = {name: _identity(folder / name) for name in FILES if (folder / name).is_file()}  # overwrite=True's

    def written(name: str) -> bool:  # by this painting
        return (folder / name).is_file() and _identity(folder / name) != before.get(name)

    try:
        use_threads(cfg.threads)
        metrics = run(paint_settings(cfg), photo, brush_named="brush" in options, callbacks=callbacks)
    except KeyboardInterrupt:
        if not written("strokes.json"):  # stopped before anything was painted: the folder as it was
            raise
        metrics = {}
    except BadInput:
        if out is None:
            _unmade(folder)
        raise
    except OSError as error:
        if error.errno not in REFUSED_WRITES:
            raise
        raise RunFailed(refused_write(error, folder)) from None
    for name in before:  # the other painting's files this one did not write anew
        if not written(name):
            (folder / name).unlink(missing_ok=True)
    return load(folder / "strokes.json", metrics)


def load(path: str | Path, metrics: dict | None = None) -> Painting:
    """A painting from its ``strokes.json``, with the ``metrics.json`` beside it."""
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
    cfg = _config("train", options, out)
    try:
        use_threads(cfg.threads)
        return run(cfg)
    except BadInput:
        if out is None:
            _unmade(Path(cfg.output_dir))
        raise


def _config(command: str, options: dict[str, Any], out: str | Path | None) -> DictConfig:
    """The command's config as its command line would compose it: a config group's option in
    ``options`` is an override, any other key is merged on its schema (so it is typed and checked)."""
    if command == "paint":
        import nsp.painting.schema  # noqa: F401  (registers paint_schema)
    groups = {p.name for p in (CONF / command).iterdir() if p.is_dir() and p.name != "hydra"} | {"brush"}
    choices = [f"{key}={value}" for key, value in options.items() if key in groups and isinstance(value, str)]
    values: dict = {}
    for key, value in options.items():
        if not (key in groups and isinstance(value, str)):  # schedule.polish=1 -> {"schedule": {"polish": 1}}
            *parents, last = key.split(".")
            tree = values
            for part in parents:
                tree = tree.setdefault(part, {})
            tree[last] = value
    try:
        with initialize_config_dir(str(CONF / command), version_base="1.3"):
            cfg = compose(command, overrides=choices, return_hydra_config=True)
    except MissingConfigException as error:  # brush="oil"
        group, _, option = (error.missing_cfg_file or "").rpartition("/")
        raise BadInput(f"{group}={option}: no such {group}; expected one of: {', '.join(error.options or [])}") from None
    HydraConfig.instance().set_config(cfg)  # as a Hydra app's run: the runtime choices name the run
    try:
        merged = OmegaConf.merge(cfg, values)
    except OmegaConfBaseException as error:  # a key the schema lacks, a value of the wrong type: as the command says it
        key, first = getattr(error, "full_key", None), str(error).strip().splitlines()[0]
        raise BadInput((key and did_you_mean(f"Could not override '{key}'", cfg)) or (f"{key}: {first}" if key else first)) from None
    merged.output_dir = str(out) if out is not None else tempfile.mkdtemp(prefix=f"nsp-{command}-")  # once all is read
    return OmegaConf.masked_copy(merged, [key for key in merged if key != "hydra"])


def _free(folder: Path, key: str, overwrite: bool) -> None:
    """Refuse (:class:`BadInput`, naming ``key``) a file, or unless ``overwrite`` a folder holding a painting."""
    if folder.exists() and not folder.is_dir():
        raise BadInput(f"{key}={folder} is a file; expected a folder for the painting's files")
    held = [name for name in FILES if (folder / name).exists()]
    if held and not overwrite:
        raise BadInput(f"{key}={folder} holds another painting ({', '.join(held)}); name another folder, "
                       "or pass overwrite=True to replace it")


def _identity(path: Path) -> tuple[int, int, int]:
    """What tells a file from one written in its place since: (device, inode, modification time)."""
    stat = path.stat()
    return stat.st_dev, stat.st_ino, stat.st_mtime_ns


def _unmade(folder: Path) -> None:
    """Remove the temporary ``folder`` of a refused call, where no file but TensorBoard's was written there."""
    if all(p.name.startswith("events.out.tfevents.") for p in folder.rglob("*") if p.is_file()):
        shutil.rmtree(folder, ignore_errors=True)


def _photo(image: Any) -> torch.Tensor:
    """A PIL image, numpy array or torch tensor as (3, H, W) float in [0, 1]; anything else is refused."""
    if isinstance(image, Image.Image):
        return from_pil(image)
    if isinstance(image, (np.ndarray, torch.Tensor)) or hasattr(image, "__array__"):
        return from_array(image)
    raise BadInput(f"image={shown(image)} ({type(image).__name__}) is not a picture; expected {ACCEPTED}")
