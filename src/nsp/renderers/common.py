"""What every renderer family shares: the output sizes, the channel-width multiplier, the input scaling,
and the renderer of one network on all stroke parameters."""
from __future__ import annotations

import torch
from torch import Tensor, nn

from nsp.brushes import get_brush
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


class OneNetwork(nn.Module):
    """A renderer drawing foreground and alpha with one ``network`` from all stroke parameters:
    ``(B, d) -> (B, 3, S, S), (B, 1, S, S)``, both in [0, 1]."""

    network: type[nn.Module]  # (in_features, out_channels, size, channel_mult) -> logits (B, out_channels, S, S)

    def __init__(self, brush: str, size: int = 128, channel_mult: float = 1.0):
        super().__init__()
        self.size = size
        self.net = self.network(get_brush(brush).d, 4, size, channel_mult)

    def forward(self, x: Tensor) -> tuple[Tensor, Tensor]:
        out = torch.sigmoid(self.net(x))
        return out[:, :3], out[:, 3:]
