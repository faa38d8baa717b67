"""The renderers ``python -m nsp.train`` saves, read back without Lightning or Hydra."""
from __future__ import annotations

import pickle
from pathlib import Path

import torch
from torch import nn

from nsp.errors import BadInput
from nsp.renderers import build


def read_checkpoint(path, map_location="cpu") -> dict:
    """A checkpoint of ``python -m nsp.train`` as saved; raises ``ValueError`` (one line) for a file
    that is missing or is not one (truncated, another program's)."""
    if not Path(path).is_file():
        raise BadInput(f"renderer checkpoint {path} does not exist")
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
        ckpt["hyper_parameters"]["renderer"]["size"], ckpt["hyper_parameters"]["brush"], ckpt["state_dict"]
    except (pickle.UnpicklingError, RuntimeError, KeyError, TypeError, IndexError, EOFError, ValueError) as error:
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise BadInput(f"{path} is not an nsp renderer checkpoint (train one with `python -m nsp.train`): {reason}") from None
    return ckpt


def check_checkpoint(path, renderer: str, brush: str, size: int) -> None:
    """Raise ``ValueError`` unless ``path`` is a checkpoint of this renderer, brush and size, to resume."""
    saved = read_checkpoint(path)["hyper_parameters"]
    theirs = (saved["renderer"].get("name"), saved["brush"], saved["renderer"]["size"])
    if theirs != (renderer, brush, size):
        raise BadInput(f"ckpt_path={path} holds renderer={theirs[0]} brush={theirs[1]} model.size={theirs[2]}; "
                         f"this run is renderer={renderer} brush={brush} model.size={size}: resume with those")


def load_renderer(path, map_location="cpu") -> tuple[nn.Module, str, int]:
    """The renderer saved in a checkpoint of ``python -m nsp.train``, in eval mode, its brush and size.

    Raises ``ValueError`` for a file that is not such a checkpoint.
    """
    ckpt = read_checkpoint(path, map_location)
    config, brush = ckpt["hyper_parameters"]["renderer"], ckpt["hyper_parameters"]["brush"]
    renderer = build(config, brush)
    prefix = "renderer."
    renderer.load_state_dict({k[len(prefix):]: v for k, v in ckpt["state_dict"].items() if k.startswith(prefix)})
    return renderer.eval(), brush, int(config["size"])
