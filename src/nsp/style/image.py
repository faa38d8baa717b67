"""Reading the style image."""
from __future__ import annotations

import os

import numpy as np
import torch
from torch import Tensor


def load_style_image(path: str | os.PathLike, long_side: int) -> Tensor:
    """The image at ``path`` as RGB (1, 3, H, W) in [0, 1], resized so max(H, W) = ``long_side``."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            image = image.convert("RGB")
    except (OSError, ValueError) as err:
        raise ValueError(f"style.image={path} is not a readable image ({err})") from None
    scale = long_side / max(image.size)
    size = (max(1, round(image.width * scale)), max(1, round(image.height * scale)))
    image = image.resize(size, Image.Resampling.LANCZOS)
    return torch.from_numpy(np.asarray(image, dtype=np.float32) / 255.0).permute(2, 0, 1)[None]
