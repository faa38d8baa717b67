"""Neural stroke renderers (paper §3.2): a stroke vector x (B, d) -> foreground (B, 3, S, S), alpha (B, 1, S, S).

One module per family; each is a plain ``nn.Module`` built from ``conf/train/renderer/*.yaml`` by
``_target_`` and knows nothing of training.
"""
from nsp.renderers.build import FAMILIES, build
from nsp.renderers.common import SIZES
from nsp.renderers.dcgan import DCGAN, ShadingNetwork
from nsp.renderers.dual import DualPathway
from nsp.renderers.pxlshuffle import PxlShuffleNet, RasterizationNetwork
from nsp.renderers.unet import UNet

__all__ = ["DCGAN", "FAMILIES", "SIZES", "DualPathway", "PxlShuffleNet", "RasterizationNetwork", "ShadingNetwork", "UNet", "build"]
