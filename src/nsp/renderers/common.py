"""What every renderer family shares: the output sizes, the channel-width multiplier, the input scaling."""
from __future__ import annotations

from torch import Tensor

from nsp.errors import BadInput

SIZES = (32, 64, 128)  # the networks double the resolution layer by layer from 4×4 (DCGAN) or 16×16 (shuffle)


def check_size(size: int) -> None:
    """Raise ``ValueError`` unless ``size`` is one of :data:`SIZES`."""
    if size not in SIZES:
        raise BadInput(f"renderer size must be one of {', '.join(map(str, SIZES))}, got {size}")


def channels(base: int, channel_mult: float) -> int:
    """``base`` channels (the paper's count) scaled by the channel multiplier, at least one."""
    return max(1, round(base * channel_mult))


def centred(x: Tensor) -> Tensor:
    """Stroke parameters in [0, 1] mapped to [-1, 1]: zero-mean inputs train several times faster."""
    return 2 * x - 1
