"""Neural stroke renderers (paper §3.2): a stroke vector x (B, d) -> foreground (B, 3, S, S), alpha (B, 1, S, S).

One module per family; each is a plain ``nn.Module`` built from ``conf/train/renderer/*.yaml`` by
``_target_`` and knows nothing of training.
"""
from __future__ import annotations

from typing import Any, Mapping

from torch import nn

from nsp.errors import BadInput
from nsp.renderers.common import SIZES, check_size
from nsp.renderers.dcgan import DCGAN, ShadingNetwork
from nsp.renderers.dual import DualPathway
from nsp.renderers.pxlshuffle import PxlShuffleNet, RasterizationNetwork
from nsp.renderers.unet import UNet


FAMILIES = {family.__name__: family for family in (DCGAN, DualPathway, PxlShuffleNet, UNet)}


def build(config: Mapping[str, Any], brush: str) -> nn.Module:
    """The renderer a ``renderer`` config node describes (``_target_``, ``size``, ``channel_mult``, …) for ``brush``.

    ``_target_`` names the family (``nsp.renderers.DualPathway``); ``name`` (the config's own label)
    is not an argument of the network. Needs no Hydra, so checkpoints load anywhere.
    """
    check_size(config["size"])
    family = str(config["_target_"]).rsplit(".", 1)[-1]
    if family not in FAMILIES:
        raise BadInput(f"renderer _target_={config['_target_']}: expected one of "
                         + ", ".join(f"nsp.renderers.{name}" for name in FAMILIES))
    arguments = {key: value for key, value in config.items() if key not in ("_target_", "name")}
    return FAMILIES[family](brush=brush, **arguments)


__all__ = ["DCGAN", "FAMILIES", "SIZES", "DualPathway", "PxlShuffleNet", "RasterizationNetwork", "ShadingNetwork", "UNet", "build"]
