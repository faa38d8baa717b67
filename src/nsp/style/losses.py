"""Style losses (paper §3.5): Gram matrices of feature maps (Gatys et al.) and a sliced-Wasserstein
colour term; :class:`StyleLoss` wraps them for the painter."""
from __future__ import annotations

import os

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsp.style.features import feature_network


def gram(features: Tensor) -> Tensor:
    """Gram matrix of feature maps (B, C, H, W) -> (B, C, C), averaged over the H·W positions."""
    f = features.flatten(2)
    return f @ f.transpose(1, 2) / f.shape[-1]


def gram_loss(grams_canvas: list[Tensor], grams_style: list[Tensor]) -> Tensor:
    """Mean over layers (and batch) of ‖G_c − G_s‖² / (‖G_c‖² + ‖G_s‖²): (B|1, C, C) each -> scalar.

    Gatys's squared Gram difference normalized to [0, 1] (ReLU Grams are non-negative), whatever the
    network's activation scale: β_sty = 0.5 then weighs a few tenths for unrelated images against a
    painter's L1 of ~0.1.
    """
    terms = []
    for g_c, g_s in zip(grams_canvas, grams_style, strict=True):
        energy = g_c.square().sum((1, 2)) + g_s.square().sum((1, 2))
        terms.append(((g_c - g_s).square().sum((1, 2)) / energy.clamp(min=1e-12)).mean())
    return torch.stack(terms).mean()


def style_loss(feats_canvas: list[Tensor], feats_style: list[Tensor]) -> Tensor:
    """Gatys style loss between two lists of feature maps (B, C, H, W), sizes may differ -> scalar."""
    return gram_loss([gram(f) for f in feats_canvas], [gram(f) for f in feats_style])


def sliced_wasserstein(canvas: Tensor, style: Tensor, projections: int = 64,
                       generator: torch.Generator | None = None) -> Tensor:
    """Sliced 1-Wasserstein distance between the RGB pixel distributions of ``canvas`` (B, 3, H, W)
    and ``style`` (B|1, 3, h, w), in RGB units like an L1 loss -> scalar, differentiable in both.

    Along each random direction transport is sorting; the style's sorted values are linearly
    resampled to the canvas's pixel count (quantile matching), so the sizes may differ.
    """
    device = generator.device if generator is not None else canvas.device
    dirs = torch.randn(3, projections, generator=generator, device=device).to(canvas)
    dirs = dirs / dirs.norm(dim=0, keepdim=True)
    a = (canvas.flatten(2).transpose(1, 2) @ dirs).sort(dim=1).values  # (B, N, P)
    b = (style.flatten(2).transpose(1, 2) @ dirs).sort(dim=1).values  # (B|1, M, P)
    if b.shape[1] != a.shape[1]:
        b = F.interpolate(b.transpose(1, 2), size=a.shape[1], mode="linear", align_corners=True).transpose(1, 2)
    return (a - b).abs().mean()


class StyleLoss(nn.Module):
    """Style loss of canvases against one style image, its Grams computed once (the painter's β_sty term).

    Args:
        image: the style image as used, (1, 3, H, W) in [0, 1]; Grams depend on the pattern's
            scale in pixels, so size it like the canvas.
        backbone: ``auto``, ``vgg19`` or ``random`` (see :func:`nsp.style.features.feature_network`).
        weights: VGG-19 state-dict path; ``None`` reads the torch hub cache.
        seed: the random backbone's filters.
    """

    def __init__(self, image: Tensor, backbone: str = "auto", weights: str | os.PathLike | None = None, seed: int = 0):
        super().__init__()
        if image.ndim != 4 or image.shape[:2] != (1, 3):
            raise ValueError(f"the style image must be (1, 3, H, W), got {tuple(image.shape)}")
        self.features = feature_network(backbone, weights, seed)
        self.register_buffer("image", image)
        with torch.no_grad():
            grams = [gram(f) for f in self.features(image)]
        self.layers = len(grams)
        for i, g in enumerate(grams):
            self.register_buffer(f"gram_{i}", g)

    @property
    def grams(self) -> list[Tensor]:
        """The style image's Gram matrices, one (1, C, C) per feature map."""
        return [getattr(self, f"gram_{i}") for i in range(self.layers)]

    def forward(self, canvas: Tensor) -> Tensor:
        """The Gram loss of ``canvas`` (B, 3, H, W) or (3, H, W) in [0, 1] against the style -> scalar."""
        canvas = canvas if canvas.ndim == 4 else canvas[None]
        return gram_loss([gram(f) for f in self.features(canvas)], self.grams)
