"""A renderer from its config node, by family name: no Hydra, so checkpoints load anywhere."""
from __future__ import annotations

from typing import Any, Mapping

from torch import nn

from nsp.errors import BadInput
from nsp.renderers.common import check_size
from nsp.renderers.dcgan import DCGAN
from nsp.renderers.dual import DualPathway
from nsp.renderers.pxlshuffle import PxlShuffleNet
from nsp.renderers.unet import UNet

FAMILIES = {family.__name__: family for family in (DCGAN, DualPathway, PxlShuffleNet, UNet)}


def build(config: Mapping[str, Any], brush: str) -> nn.Module:
    """The renderer a ``renderer`` config node describes for ``brush``: ``_target_`` names the family
    (``nsp.renderers.DualPathway``); the other keys but ``name`` (the config's own label) are its arguments."""
    check_size(config["size"])
    family = str(config["_target_"]).rsplit(".", 1)[-1]
    if family not in FAMILIES:
        raise BadInput(f"renderer _target_={config['_target_']}: expected one of "
                         + ", ".join(f"nsp.renderers.{name}" for name in FAMILIES))
    arguments = {key: value for key, value in config.items() if key not in ("_target_", "name")}
    return FAMILIES[family](brush=brush, **arguments)
