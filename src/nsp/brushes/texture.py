"""A user's grayscale image as the oil brush's texture (nsp's own is :mod:`nsp.brushes.bristles`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from nsp.errors import BadInput


def load_texture(path: str | Path) -> Tensor:
    """A user's grayscale texture image as (H, W) in [0, 1]; dark means no paint."""
    from PIL import Image

    try:
        image = Image.open(path).convert("L")
    except (OSError, ValueError) as err:
        raise BadInput(f"brush.texture={path} is not a readable image ({err})") from None
    return torch.from_numpy(np.asarray(image, dtype=np.float32) / 255.0)
