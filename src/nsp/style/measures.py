"""How a stylized painting (paper §3.5) compares with its plain painting, its photo and its style.

Images are RGB (3, H, W) in [0, 1]; each measure returns a float.

- :func:`color_distance`: how far the painting's colours are from the style's (lower: closer).
- :func:`coherence`: how far apart colours that were alike in the plain painting end up (lower:
  a more coherent recolouring; an identical or shared recolouring keeps them within their ≤ 0.03).
- :func:`luminance_ssim`: whether the photo's luminance structure still reads (higher: better).
- :func:`texture_distance`: the Gram distance to the style on a random network held out from
  the one the style steps used (lower: closer textures).
"""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.painter.images import ssim
from nsp.style.color import rgb_to_lab
from nsp.style.features import random_features
from nsp.style.losses import sliced_wasserstein, style_loss

NEAR = 0.03  # RGB distance under which two colours of the plain painting count as alike
HELD_OUT_SEED = 1000  # the held-out network's filters; the style steps use nsp.paint's seed


def color_distance(image: Tensor, style: Tensor, projections: int = 256, seed: int = 0) -> float:
    """Sliced 1-Wasserstein distance between the pixel colours of ``image`` and ``style`` (3, h, w)
    in L*a*b* / 100 (a unit is 100 ΔE), over ``projections`` seeded directions."""
    generator = torch.Generator().manual_seed(seed)
    lab = [rgb_to_lab(x.detach().float(), dim=0)[None] for x in (image, style)]
    return float(sliced_wasserstein(*lab, projections, generator))


def coherence(plain: Tensor, styled: Tensor, near: float = NEAR, samples: int = 2048, seed: int = 0) -> float:
    """Mean RGB distance in ``styled`` between the pixels whose colours lay within ``near`` of each
    other in ``plain`` (same size), over all pairs of ``samples`` seeded pixels; NaN if no pair is."""
    if plain.shape != styled.shape:
        raise ValueError(f"coherence compares one painting twice: got {tuple(plain.shape)} and {tuple(styled.shape)}")
    generator = torch.Generator().manual_seed(seed)
    pick = torch.randperm(plain[0].numel(), generator=generator)[:samples]
    before, after = (x.detach().flatten(1)[:, pick].T.double() for x in (plain, styled))
    alike = torch.cdist(before, before) < near
    alike.fill_diagonal_(False)
    return float(torch.cdist(after, after)[alike].mean())


def luminance_ssim(painting: Tensor, photo: Tensor) -> float:
    """SSIM of the lightness L* (:mod:`nsp.style.color`) of ``painting`` and ``photo`` (same size),
    with a Gaussian window (σ = 1.5), as ``nsp.painter.outputs.similarity`` compares colours."""
    if painting.shape != photo.shape:
        raise ValueError(f"luminance_ssim needs images of one size: got {tuple(painting.shape)} and "
                         f"{tuple(photo.shape)}")
    a, b = (rgb_to_lab(x.detach().cpu().double(), dim=0)[:1] for x in (painting, photo))
    return float(ssim(a, b))


def texture_distance(image: Tensor, style: Tensor, seed: int = HELD_OUT_SEED) -> float:
    """Gram distance (:func:`nsp.style.style_loss`, in [0, 1]) between ``image`` and ``style``
    (3, h, w) on the random multi-scale filters of ``seed``."""
    net = random_features(seed)
    with torch.no_grad():
        return float(style_loss(net(image[None].float()), net(style[None].float())))
