"""A renderer from its config node: the class its ``_target_`` names, imported (nsp's families, or
a class of your own on ``PYTHONPATH``); no Hydra, so checkpoints load anywhere."""
from __future__ import annotations

import importlib
from typing import Any, Mapping

from torch import nn

from nsp.errors import BadInput
from nsp.renderers.common import check_size

FAMILIES = ("nsp.renderers.DCGAN", "nsp.renderers.DualPathway", "nsp.renderers.PxlShuffleNet", "nsp.renderers.UNet")


def build(config: Mapping[str, Any], brush: str) -> nn.Module:
    """The renderer a ``renderer`` config node describes for ``brush``: ``_target_`` names its class
    (``nsp.renderers.DualPathway``, or ``my_module.MyRenderer``), an ``nn.Module`` made as
    ``cls(brush=brush, size=…, channel_mult=…, **its other keys)``; ``name`` is the config's own label.
    :class:`BadInput` for a target that cannot be imported or is not an ``nn.Module`` subclass."""
    check_size(config["size"])
    target = str(config["_target_"])
    module, _, name = target.rpartition(".")
    try:
        family = getattr(importlib.import_module(module), name) if module else None
    except (ImportError, AttributeError) as error:
        family = error
    if not isinstance(family, type) or not issubclass(family, nn.Module):
        why = f" ({type(family).__name__}: {family})" if isinstance(family, Exception) else ""
        raise BadInput(f"renderer _target_={target}: not a torch.nn.Module subclass that imports{why}; expected one of "
                       f"{', '.join(FAMILIES)}, or a class of yours on PYTHONPATH")
    arguments = {key: value for key, value in config.items() if key not in ("_target_", "name")}
    return family(brush=brush, **arguments)
