"""How a stylized painting (paper §3.5) compares with its plain painting, its photo and its style:
:func:`color_distance` and :func:`texture_distance` to the style (lower: closer; textures on a random
network held out from the style steps'), :func:`coherence` of the colours alike in the plain painting
(lower: more coherent) and :func:`luminance_ssim` to the photo (higher: its structure still reads).
Images are RGB (3, H, W) in [0, 1]; each measure returns a float.
"""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.colors import rgb_to_lab
from nsp.images import ssim
from nsp.style.features import random_features
from nsp.style.losses import sliced_wasserstein, style_loss

NEAR = 0.03  # RGB distance under which two colours of the plain painting count as alike
SAMPLES = 8192  # the pixels coherence pairs up: all of them on a canvas up to 90×90 (the studies' 80 px)
HELD_OUT_SEED = 1000  # the held-out network's filters; the style steps use nsp.paint's seed


def color_distance(image: Tensor, style: Tensor, projections: int = 256, seed: int = 0) -> float:
    """Sliced 1-Wasserstein distance between the pixel colours of ``image`` and ``style`` (3, h, w)
    in L*a*b* / 100 (a unit is 100 ΔE), over ``projections`` seeded directions."""
    generator = torch.Generator().manual_seed(seed)
    lab = [rgb_to_lab(x.detach().float(), dim=0)[None] for x in (image, style)]
    return float(sliced_wasserstein(*lab, projections, generator))


def coherence(plain: Tensor, styled: Tensor, samples: int = SAMPLES, seed: int = 0) -> float:
    """Mean RGB distance in ``styled`` between the pixels whose colours lay within :data:`NEAR` of
    each other in ``plain`` (same size), over all pairs of ``samples`` seeded pixels (every pixel,
    where the painting has no more: then exact, whatever the seed); NaN if no pair is."""
    if plain.shape != styled.shape:
        raise ValueError(f"coherence compares one painting twice: got {tuple(plain.shape)} and {tuple(styled.shape)}")
    pairs = alike_pairs(plain.detach().flatten(1).T.float(), samples, torch.Generator().manual_seed(seed))
    return float(parted(styled.detach().double(), *pairs))


def alike_pairs(colors: Tensor, rows: int, generator: torch.Generator) -> tuple[Tensor, Tensor]:
    """Indices (P,), (P,) of the pairs among ``rows`` seeded rows of ``colors`` (N, 3; all N rows
    where ``rows`` ≥ N) that lie within :data:`NEAR` of each other, each pair once."""
    pick = torch.randperm(len(colors), generator=generator)[:rows]
    first, second = (torch.cdist(colors[pick], colors[pick]) < NEAR).triu(1).nonzero().unbind(1)
    return pick[first], pick[second]


def parted(image: Tensor, first: Tensor, second: Tensor) -> Tensor:
    """Mean RGB distance in ``image`` (3, H, W, or 3, N pixels) between the pixels ``first`` (P,)
    and ``second`` (P,) of :func:`alike_pairs`: how far alike colours have parted; NaN if P = 0."""
    pixels = image.flatten(1)
    return (pixels[:, first] - pixels[:, second]).norm(dim=0).mean()


def luminance_ssim(painting: Tensor, photo: Tensor) -> float:
    """SSIM of the lightness L* (:mod:`nsp.colors`) of ``painting`` and ``photo`` (same size),
    with a Gaussian window (σ = 1.5), as ``nsp.painting.outputs.similarity`` compares colours."""
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
