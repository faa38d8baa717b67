"""UNet (pix2pix-style) on the stroke vector tiled to a d×S×S image.

The encoder halves the resolution with 4×4 convolutions down to 1×1 (64, 128, 256, 512, 512, …
channels at channel_mult 1); the decoder mirrors it with transposed convolutions and skip connections.
"""
from __future__ import annotations

import math

import torch
from torch import Tensor, nn

from nsp.brushes import get_brush
from nsp.renderers.common import centred, channels, check_size


class UNet(nn.Module):
    """UNet renderer: ``(B, d) -> (B, 3, S, S), (B, 1, S, S)``, both in [0, 1]."""

    def __init__(self, brush: str, size: int = 128, channel_mult: float = 1.0):
        super().__init__()
        check_size(size)
        self.size = size
        depth = int(math.log2(size))  # halvings from S×S to 1×1
        widths = [channels(64 * min(2**i, 8), channel_mult) for i in range(depth)]

        self.down = nn.ModuleList()
        for i, (c_in, c_out) in enumerate(zip([get_brush(brush).d, *widths], widths)):
            norm = 0 < i < depth - 1  # no BN on the input layer nor on the 1×1 bottleneck
            self.down.append(nn.Sequential(nn.Conv2d(c_in, c_out, 4, 2, 1, bias=not norm),
                                           nn.BatchNorm2d(c_out) if norm else nn.Identity(),
                                           nn.LeakyReLU(0.2, inplace=True)))
        self.up = nn.ModuleList()
        for i in range(depth - 1, 0, -1):
            c_in = widths[i] if i == depth - 1 else 2 * widths[i]  # the bottleneck has no skip yet
            self.up.append(nn.Sequential(nn.ConvTranspose2d(c_in, widths[i - 1], 4, 2, 1, bias=False),
                                         nn.BatchNorm2d(widths[i - 1]), nn.ReLU(inplace=True)))
        self.out = nn.ConvTranspose2d(2 * widths[0], 4, 4, 2, 1)

    def forward(self, x: Tensor) -> tuple[Tensor, Tensor]:
        h = centred(x)[:, :, None, None].expand(-1, -1, self.size, self.size)
        skips = []
        for layer in self.down:
            h = layer(h)
            skips.append(h)
        h = skips.pop()
        for layer in self.up:
            h = torch.cat([layer(h), skips.pop()], 1)
        out = torch.sigmoid(self.out(h))
        return out[:, :3], out[:, 3:]
