"""The paper's dual-pathway renderer (§3.2) and its one-pathway ablations (Table 1).

The rasterization pathway G_r (PxlShuffleNet) sees the shape parameters only and draws the silhouette;
the shading pathway G_s (DCGAN-G) sees all parameters and paints the colour map. Foreground
s = colour · support and alpha α = A · coverage, A the brush's transparency (1 if opaque), so colour and
transparency cannot leak into the shape.

Unlike the paper's one silhouette, G_r draws two: the *support* (where the engine puts colour, a hard
edge) and the *coverage* (the antialiased, for oil textured, alpha / A). With one, s = colour · coverage
misses the engine's foreground on every antialiased edge pixel, which alone caps PSNR(s) near 22 dB at
32 px and 28 dB at 128 px. ``silhouettes=1`` is the paper's renderer, its silhouette both.
"""
from __future__ import annotations

from typing import Sequence

import torch
from torch import Tensor, nn

from nsp.brushes import get_brush
from nsp.errors import BadInput
from nsp.renderers.dcgan import ShadingNetwork
from nsp.renderers.pxlshuffle import RasterizationNetwork

PATHWAYS = ("rasterization", "shading")


class DualPathway(nn.Module):
    """Dual-pathway renderer: ``(B, d) -> (B, 3, S, S), (B, 1, S, S)``, both in [0, 1].

    Args:
        brush: brush name; gives d and which parameters are shape and transparency.
        size: output side S (32, 64 or 128).
        channel_mult: channel multiplier (1 = the paper's layers).
        pathways: both (the paper's renderer), or one alone (the ablations ``dual_raster``,
            ``dual_shading``), which then sees all parameters and draws colour and silhouette itself.
        silhouettes: 2 (support and coverage) or 1 (the paper's: one map is both).
    """

    def __init__(self, brush: str, size: int = 128, channel_mult: float = 1.0, pathways: Sequence[str] = PATHWAYS,
                 silhouettes: int = 2):
        super().__init__()
        pathways = tuple(pathways)
        if not pathways or not set(pathways) <= set(PATHWAYS):
            raise BadInput(f"pathways must be a non-empty subset of {list(PATHWAYS)}, got {list(pathways)}")
        if silhouettes not in (1, 2):
            raise BadInput(f"silhouettes={silhouettes}: expected 1 (the paper's) or 2 (support and coverage)")
        spec = get_brush(brush)
        self.size, self.shape_index, self.alpha_index = size, list(spec.shape), spec.alpha
        self.silhouettes = silhouettes
        self.rasterization = self.shading = None
        if len(set(pathways)) == 2:
            self.rasterization = RasterizationNetwork(len(spec.shape), silhouettes, size, channel_mult)
            self.shading = ShadingNetwork(spec.d, 3, size, channel_mult)
        elif pathways[0] == "rasterization":
            self.rasterization = RasterizationNetwork(spec.d, 3 + silhouettes, size, channel_mult)
        else:
            self.shading = ShadingNetwork(spec.d, 3 + silhouettes, size, channel_mult)

    def maps(self, x: Tensor) -> tuple[Tensor, Tensor, Tensor]:
        """Colour (B, 3, S, S), support (B, 1, S, S) and coverage (B, 1, S, S), all in [0, 1]; with one
        silhouette, support and coverage are the same map."""
        if self.rasterization is not None and self.shading is not None:
            colour = torch.sigmoid(self.shading(x))
            silhouettes = torch.sigmoid(self.rasterization(x[:, self.shape_index]))
        else:
            net = self.rasterization if self.rasterization is not None else self.shading
            colour, silhouettes = torch.sigmoid(net(x)).split([3, self.silhouettes], 1)
        support, coverage = silhouettes.split(1, 1) if self.silhouettes == 2 else (silhouettes, silhouettes)
        return colour, support, coverage

    def forward(self, x: Tensor) -> tuple[Tensor, Tensor]:
        colour, support, coverage = self.maps(x)
        transparency = 1.0 if self.alpha_index is None else x[:, self.alpha_index, None, None, None]
        return colour * support, transparency * coverage
