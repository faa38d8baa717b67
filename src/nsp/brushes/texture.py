"""The oil brush's bristle texture: nsp's own, procedural and deterministic, or a user's image."""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.errors import BadInput


def _smooth_noise(n: int, knots: int, generator: torch.Generator) -> Tensor:
    """1-D value noise: ``knots`` random values in [0, 1], linearly resampled to ``n`` points."""
    values = torch.rand(1, 1, knots, generator=generator, device="cpu")
    return F.interpolate(values, size=n, mode="linear", align_corners=True)[0, 0]


@lru_cache(maxsize=8)
def bristle_texture(height: int = 48, width: int = 192, seed: int = 0) -> Tensor:
    """Grayscale bristle streaks, (height, width) in [0, 1]; u runs along the width (head → tail).

    Each row is one bristle track: its brightness varies smoothly across rows (streaks), it starts
    and ends at slightly different places (ragged head and tail), and paint thins towards the tail.
    Zero means no paint.
    """
    g = torch.Generator().manual_seed(seed)
    v = torch.linspace(-1, 1, height, device="cpu")[:, None]  # built on the CPU, moved where it is used
    u = torch.linspace(0, 1, width, device="cpu")[None, :]
    streaks = 0.55 + 0.45 * _smooth_noise(height, height // 2, g)[:, None]
    fine = 0.9 + 0.1 * torch.rand(height, 1, generator=g, device="cpu")
    envelope = torch.sqrt((1 - v**4).clamp(min=0))  # rounded sides: outer bristles are shorter
    start = 0.02 + 0.10 * _smooth_noise(height, height // 3, g)[:, None] + 0.05 * (1 - envelope)
    end = (0.86 + 0.13 * _smooth_noise(height, height // 3, g)[:, None]) * (0.8 + 0.2 * envelope)
    support = torch.sigmoid((u - start) / 0.012) * torch.sigmoid((end - u) / 0.012)
    thinning = 1 - 0.25 * u + 0.05 * _smooth_noise(width, 12, g)[None, :]
    return (support * streaks * fine * thinning).clamp(0, 1).contiguous()


def load_texture(path: str | Path) -> Tensor:
    """A user's grayscale texture image as (H, W) in [0, 1]; dark means no paint."""
    from PIL import Image

    try:
        image = Image.open(path).convert("L")
    except (OSError, ValueError) as err:
        raise BadInput(f"brush.texture={path} is not a readable image ({err})") from None
    return torch.from_numpy(np.asarray(image, dtype=np.float32) / 255.0)
