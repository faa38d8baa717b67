"""The renderers ``python -m nsp.train`` saves, read back without Lightning or Hydra."""
from __future__ import annotations

import pickle
from pathlib import Path

import torch
from torch import nn

from nsp.errors import BadInput
from nsp.renderers import build


def read_checkpoint(path, map_location="cpu") -> dict:
    """A checkpoint of ``python -m nsp.train`` as saved; :class:`BadInput` (one line) for a file that is
    missing or is not one (truncated, another program's)."""
    if not Path(path).is_file():
        raise BadInput(f"renderer checkpoint {path} does not exist")
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
        ckpt["hyper_parameters"]["renderer"]["size"], ckpt["hyper_parameters"]["brush"], ckpt["state_dict"]
    except (pickle.UnpicklingError, RuntimeError, KeyError, TypeError, IndexError, EOFError, ValueError) as error:
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise BadInput(f"{path} is not an nsp renderer checkpoint (train one with `python -m nsp.train`): {reason}") from None
    return ckpt


def check_checkpoint(path, renderer: dict, brush: str) -> None:
    """Raise :class:`BadInput` unless ``path`` is a whole checkpoint (its weights fit the renderer it
    names) of the ``renderer`` config (``name``, ``size``, ``channel_mult``, …) and ``brush``, to resume."""
    saved = read_checkpoint(path)["hyper_parameters"]
    theirs = (saved["renderer"].get("name"), saved["brush"], saved["renderer"]["size"])
    if theirs != (renderer["name"], brush, renderer["size"]):
        raise BadInput(f"ckpt_path={path} holds renderer={theirs[0]} brush={theirs[1]} model.size={theirs[2]}; "
                       f"this run is renderer={renderer['name']} brush={brush} model.size={renderer['size']}: resume with those")
    if differ := [key for key in renderer if key != "_target_" and saved["renderer"].get(key) != renderer[key]]:
        given = " ".join(f"{OPTIONS.get(key, 'renderer.' + key)}={saved['renderer'].get(key)}" for key in differ)
        raise BadInput(f"ckpt_path={path} was trained with {given}; this run differs: resume with those")
    load_renderer(path)


OPTIONS = {"size": "model.size", "channel_mult": "model.channel_mult"}  # renderer keys a training run sets as model.*


def checkpoint_brush(path) -> str:
    """The brush whose strokes the renderer in checkpoint ``path`` learned (:class:`BadInput` if it is none)."""
    return read_checkpoint(path)["hyper_parameters"]["brush"]


def load_renderer(path, map_location="cpu") -> tuple[nn.Module, str, int]:
    """The renderer saved in a checkpoint of ``python -m nsp.train``, in eval mode, its brush and size;
    :class:`BadInput` for a file that is not one, or whose weights do not fit the renderer it describes."""
    ckpt = read_checkpoint(path, map_location)
    config, brush = ckpt["hyper_parameters"]["renderer"], ckpt["hyper_parameters"]["brush"]
    prefix = "renderer."
    try:
        renderer = build(config, brush)
        renderer.load_state_dict({k[len(prefix):]: v for k, v in ckpt["state_dict"].items() if k.startswith(prefix)})
    except BadInput as error:  # a brush or family it names that nsp does not have
        raise BadInput(f"{path}: {error}") from None
    except (TypeError, KeyError, ValueError, RuntimeError, AttributeError) as error:
        lines = [line.strip() for line in str(error).splitlines() if line.strip() and "Error(s) in loading" not in line]
        reason = lines[0] if lines else type(error).__name__
        raise BadInput(f"{path}: its weights do not fit the renderer its settings describe "
                       f"({reason if len(reason) <= 100 else reason[:99] + '…'}); use a checkpoint `python -m nsp.train` wrote") from None
    return renderer.eval(), brush, int(config["size"])
