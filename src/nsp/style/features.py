"""Feature networks for the style loss (paper §3.5): images (B, 3, H, W) in [0, 1] -> list of
feature maps (B, C_i, H_i, W_i), frozen.

``vgg19``: torchvision's VGG-19 with ImageNet weights, read from a local file only (never
downloaded). ``random``: one layer of random multi-scale filters (Ustyuzhaninov et al., ICLR 2017),
which needs no pretrained weights.
"""
from __future__ import annotations

import os
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsp.config import BACKBONES

MIN_SIDE = 4  # the smallest image side both take: two halvings (random: its 4× scale; VGG-19 to relu3_3: two max-pools)


class WeightsNotFound(FileNotFoundError):
    """The VGG-19 weights file is nowhere it was looked for."""


class ImageNetNormalize(nn.Module):
    """The input normalization the ImageNet weights expect (torchvision's ``IMAGENET1K`` preset's
    mean and std), here so that the random backbone runs without importing torchvision (2 s)."""

    def __init__(self):
        super().__init__()
        self.register_buffer("mean", torch.tensor([0.485, 0.456, 0.406])[:, None, None], persistent=False)
        self.register_buffer("std", torch.tensor([0.229, 0.224, 0.225])[:, None, None], persistent=False)

    def forward(self, images: Tensor) -> Tensor:
        return (images - self.mean) / self.std


VGG19_FILE = "vgg19-dcbb9e9d.pth"  # torchvision's VGG19_Weights.IMAGENET1K_V1 file (a test holds them equal)


def hub_cache_path() -> Path:
    """Where torchvision keeps the ``VGG19_Weights.IMAGENET1K_V1`` file once downloaded (found
    without importing torchvision, which takes seconds)."""
    return Path(torch.hub.get_dir()) / "checkpoints" / VGG19_FILE


def chosen_backbone(backbone: str, weights: str | os.PathLike | None = None) -> str:
    """The network ``style.backbone`` names: ``auto`` is ``vgg19`` where its ``weights`` file (or
    the hub cache's) exists, else ``random``; the others as given."""
    if backbone != "auto":
        return backbone
    return "vgg19" if (Path(weights) if weights is not None else hub_cache_path()).is_file() else "random"


class TappedFeatures(nn.Module):
    """Outputs of chosen modules of a sequential network: (B, 3, H, W) in [0, 1] -> list of maps."""

    def __init__(self, body: nn.Sequential, taps: tuple[int, ...]):
        super().__init__()
        self.normalize, self.body, self.taps = ImageNetNormalize(), body, frozenset(taps)

    def forward(self, images: Tensor) -> list[Tensor]:
        x = self.normalize(images)
        out = []
        for i, layer in enumerate(self.body):
            x = layer(x)
            if i in self.taps:
                out.append(x)
        return out


def vgg19_features(weights: str | os.PathLike | None = None, layers: tuple[int, ...] = (2, 4, 7)) -> TappedFeatures:
    """VGG-19 activations after the ReLU of the given conv layers (1-based, counting the convs of
    torchvision's ``vgg19().features``; paper: 2nd, 4th, 7th = relu1_2, relu2_2, relu3_3), built only
    up to the last of them.

    ``weights``: a state dict file of torchvision's ``vgg19``, the full model's keys (``features.0.weight``)
    or those of ``features`` alone (``0.weight``); ``None`` reads the hub cache file. Nothing is downloaded.
    """
    from torchvision.models.vgg import cfgs, make_layers

    path = Path(weights) if weights is not None else hub_cache_path()
    if not path.is_file():
        raise WeightsNotFound(
            f"VGG-19 weights not found at {path}; on a machine with internet run "
            f"python -c \"import torchvision; torchvision.models.vgg19(weights='IMAGENET1K_V1')\" "
            f"and copy ~/.cache/torch/hub/checkpoints/{hub_cache_path().name} from there to {hub_cache_path()} "
            f"(or anywhere, and pass style.weights=PATH); style.backbone=random needs no weights"
        )
    cfg, convs = [], 0
    for v in cfgs["E"]:  # torchvision's VGG-19 layout, cut after the last conv needed
        if convs == max(layers):
            break
        cfg.append(v)
        convs += v != "M"
    with torch.device("meta"):  # no random init (and no global RNG use): every weight is loaded
        body = make_layers(cfg)
    conv_at = [i for i, m in enumerate(body) if isinstance(m, nn.Conv2d)]
    taps = tuple(conv_at[n - 1] + 1 for n in layers)  # the ReLU after each chosen conv

    state = torch.load(path, map_location="cpu", weights_only=True)
    if any(k.startswith("features.") for k in state):
        state = {k.removeprefix("features."): v for k, v in state.items() if k.startswith("features.")}
    wanted = body.state_dict().keys()
    missing = sorted(set(wanted) - state.keys())
    if missing:
        raise ValueError(f"{path} is not a VGG-19 state dict: it lacks features.{missing[0]}")
    body.load_state_dict({k: state[k] for k in wanted}, assign=True)
    return TappedFeatures(body, taps).requires_grad_(False).eval()


class RandomFeatures(nn.Module):
    """One convolutional layer of random filters of several sizes, ReLU, at several image scales.

    Ustyuzhaninov et al. (2017) use one random layer with filters of 3 to 55 px; here the large sizes come,
    much cheaper, from small kernels on 2×- and 4×-downsampled images. Output: one map per scale s,
    (B, filters·len(kernel_sizes), H/2^s, W/2^s).
    """

    def __init__(self, seed: int = 0, filters: int = 32, kernel_sizes: tuple[int, ...] = (3, 5, 7, 11), scales: int = 3):
        super().__init__()
        self.normalize = ImageNetNormalize()
        self.scales, self.kernel_sizes = scales, kernel_sizes
        generator = torch.Generator().manual_seed(seed)
        for k in kernel_sizes:
            w = torch.randn(filters, 3, k, k, generator=generator)
            w = w - w.mean((1, 2, 3), keepdim=True)  # zero-mean: respond to structure and hue, not brightness
            self.register_buffer(f"weight_{k}", w / w.flatten(1).norm(dim=1)[:, None, None, None])

    def forward(self, images: Tensor) -> list[Tensor]:
        x = self.normalize(images)
        out = []
        for s in range(self.scales):
            xs = F.avg_pool2d(x, 2**s) if s else x
            maps = [F.conv2d(F.pad(xs, (k // 2,) * 4, mode="replicate"), getattr(self, f"weight_{k}"))
                    for k in self.kernel_sizes]
            out.append(F.relu(torch.cat(maps, 1)))
        return out


def random_features(seed: int = 0, **kwargs) -> RandomFeatures:
    """Random multi-scale features, identical for the same ``seed``; ``kwargs`` go to :class:`RandomFeatures`."""
    return RandomFeatures(seed, **kwargs).requires_grad_(False).eval()


def feature_network(backbone: str, weights: str | os.PathLike | None = None, seed: int = 0) -> nn.Module:
    """The ``style.backbone`` network: ``vgg19`` (reads ``weights``), ``random`` (uses ``seed``), or
    ``auto``: the first where its weights are found (:func:`chosen_backbone`)."""
    backbone = chosen_backbone(backbone, weights)
    if backbone == "vgg19":
        return vgg19_features(weights)
    if backbone == "random":
        return random_features(seed)
    raise ValueError(f"unknown style.backbone '{backbone}', expected one of: {', '.join(BACKBONES)}")
