"""Neural stroke renderers (paper §3.2): a stroke vector x (B, d) -> foreground (B, 3, S, S), alpha (B, 1, S, S).

One module per family; each is a plain ``nn.Module`` built from ``conf/train/renderer/*.yaml`` by
``_target_`` and knows nothing of training.
"""
from __future__ import annotations

from typing import Any, Mapping

from hydra.utils import instantiate
from torch import nn

from nsp.renderers.common import SIZES, check_size
from nsp.renderers.dcgan import DCGAN, ShadingNetwork
from nsp.renderers.dual import DualPathway
from nsp.renderers.pxlshuffle import PxlShuffleNet, RasterizationNetwork
from nsp.renderers.unet import UNet


def build(config: Mapping[str, Any], brush: str) -> nn.Module:
    """The renderer a ``renderer`` config node describes (``_target_``, ``size``, ``channel_mult``, …) for ``brush``.

    ``name`` (the config's own label) is not an argument of the network.
    """
    check_size(config["size"])  # before instantiate, which would wrap the error in its own
    arguments = {key: value for key, value in config.items() if key != "name"}
    return instantiate(arguments, brush=brush, _convert_="all")


__all__ = ["DCGAN", "SIZES", "DualPathway", "PxlShuffleNet", "RasterizationNetwork", "ShadingNetwork", "UNet", "build"]
