"""PxlShuffleNet (Huang et al. 2019): fully connected layers, a 16×16 view, a conv/pixel-shuffle decoder.

The paper's rasterization network (appendix table) is this network: at S = 128 and channel_mult 1 its
layers are F1..F4 512-1024-2048-4096 · view 16×16×16 · three stages of Conv 3×3 + ReLU, Conv 3×3 +
pixel shuffle ×2 with (32, 32), (16, 16), (8, 4) filters, ending at 128×128×1.
A smaller S stops at its resolution: the stage that reaches S draws the outputs.
"""
from __future__ import annotations

import math

from torch import Tensor, nn

from nsp.renderers.common import OneNetwork, centred, channels, check_size

PAPER_FEATURES = (512, 1024, 2048)  # F1..F3; F4 is the 16×16 view
PAPER_STAGES = ((32, 8), (16, 4), (8, 1))  # per stage: conv filters, channels after the shuffle


class RasterizationNetwork(nn.Module):
    """(B, in_features) -> (B, out_channels, S, S) logits."""

    def __init__(self, in_features: int, out_channels: int, size: int = 128, channel_mult: float = 1.0):
        super().__init__()
        check_size(size)
        self.view = channels(16, channel_mult)  # F4 has view·16·16 features: 4096 at channel_mult 1
        features = [channels(f, channel_mult) for f in PAPER_FEATURES] + [self.view * 256]
        fc: list[nn.Module] = []
        for f_in, f_out in zip([in_features, *features], features):
            fc += [nn.Linear(f_in, f_out), nn.ReLU(inplace=True)]
        self.fc = nn.Sequential(*fc)

        n_stages = int(math.log2(size // 16))
        stages = [(channels(a, channel_mult), channels(b, channel_mult)) for a, b in PAPER_STAGES[:n_stages]]
        stages[-1] = (stages[-1][0], out_channels)  # the last stage draws the outputs
        convs: list[nn.Module] = []
        c_in = self.view
        for a, b in stages:
            convs += [nn.Conv2d(c_in, a, 3, padding=1), nn.ReLU(inplace=True),
                      nn.Conv2d(a, 4 * b, 3, padding=1), nn.PixelShuffle(2)]  # 4·b channels at R×R -> b at 2R×2R
            c_in = b
        self.convs = nn.Sequential(*convs)

    def forward(self, x: Tensor) -> Tensor:
        return self.convs(self.fc(centred(x)).view(-1, self.view, 16, 16))


class PxlShuffleNet(OneNetwork):
    """PxlShuffleNet renderer: ``(B, d) -> (B, 3, S, S), (B, 1, S, S)`` from one fully connected + shuffle network."""

    network = RasterizationNetwork
