"""DCGAN-G: a stack of 4×4 transposed convolutions with BN + ReLU, each doubling the resolution.

The paper's shading network (appendix table) is this stack: at S = 128 and channel_mult 1 its layers are
C1 512×4×4/1 (4×4) · C2 512/2 (8×8) · C3 256/2 · C4 128/2 · C5 64/2 · C6 out/2 (128×128).
A smaller S keeps the output end, as DCGAN generators for small images do: 64 filters before the
output, doubling towards the input (32 px: 256 (4×4) · 128 (8×8) · 64 (16×16) · out).
"""
from __future__ import annotations

import math

from torch import Tensor, nn

from nsp.renderers.common import OneNetwork, centred, channels, check_size

PAPER_CHANNELS = (512, 512, 256, 128, 64)  # C1..C5; C6 is the output layer


class ShadingNetwork(nn.Module):
    """(B, in_features) -> (B, out_channels, S, S) logits."""

    def __init__(self, in_features: int, out_channels: int, size: int = 128, channel_mult: float = 1.0):
        super().__init__()
        check_size(size)
        hidden = [channels(c, channel_mult) for c in PAPER_CHANNELS[-int(math.log2(size // 4)) :]]
        layers: list[nn.Module] = []
        for i, (c_in, c_out) in enumerate(zip([in_features, *hidden], hidden)):
            first = i == 0  # C1 turns the 1×1 input into 4×4; the others double the resolution
            layers += [nn.ConvTranspose2d(c_in, c_out, 4, 1 if first else 2, 0 if first else 1, bias=False),
                       nn.BatchNorm2d(c_out), nn.ReLU(inplace=True)]
        layers.append(nn.ConvTranspose2d(hidden[-1], out_channels, 4, 2, 1))
        self.layers = nn.Sequential(*layers)

    def forward(self, x: Tensor) -> Tensor:
        return self.layers(centred(x)[:, :, None, None])


class DCGAN(OneNetwork):
    """DCGAN-G renderer: ``(B, d) -> (B, 3, S, S), (B, 1, S, S)`` from one transposed-conv stack."""

    network = ShadingNetwork
