"""Target photos: a file, or one of the photos that ship with scikit-image / scikit-learn (SPEC §7)."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image
from torch import Tensor


def _skimage(name: str) -> Callable[[], np.ndarray]:
    def load() -> np.ndarray:
        import skimage.data

        return getattr(skimage.data, name)()

    return load


def _sklearn(name: str) -> Callable[[], np.ndarray]:
    def load() -> np.ndarray:
        from sklearn.datasets import load_sample_image  # imported only when asked: slow to import

        return load_sample_image(name)

    return load


BUILTIN: dict[str, Callable[[], np.ndarray]] = {
    "astronaut": _skimage("astronaut"),
    "chelsea": _skimage("chelsea"),
    "coffee": _skimage("coffee"),
    "rocket": _skimage("rocket"),
    "flower": _sklearn("flower.jpg"),
    "china": _sklearn("china.jpg"),
}


class ImageError(ValueError):
    """An ``image=`` that cannot be painted; the message names it and what is valid."""


def load_image(spec: str) -> Tensor:
    """A built-in photo's name or an image file's path -> (3, H, W) float in [0, 1].

    Transparent pixels are shown over white, as an image viewer does.
    """
    if spec in BUILTIN:
        array = BUILTIN[spec]()
    else:
        path = Path(spec)
        valid = f"give a PNG/JPEG path or one of: {', '.join(BUILTIN)}"
        if not path.is_file():
            raise ImageError(f"image={spec}: no such file; {valid}")
        try:
            with Image.open(path) as image:
                rgba = image.convert("RGBA")
        except (OSError, ValueError, Image.DecompressionBombError) as error:
            raise ImageError(f"image={spec} is not an image this can read ({error}); {valid}") from None
        white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
        array = np.asarray(Image.alpha_composite(white, rgba).convert("RGB"))
    if array.ndim == 2:  # grayscale built-ins
        array = np.repeat(array[..., None], 3, -1)
    return torch.from_numpy(np.array(array[..., :3])).permute(2, 0, 1).float() / 255


def long_side(height: int, width: int, size: int) -> tuple[int, int]:
    """(height, width) scaled so the longer side is ``size``, aspect kept."""
    scale = size / max(height, width)
    return max(1, round(height * scale)), max(1, round(width * scale))


def resize(image: Tensor, size: int | tuple[int, int]) -> Tensor:
    """(3, H, W) -> (3, h, w): long side ``size`` (aspect kept), or exactly (h, w) = ``size``;
    antialiased when shrinking."""
    shape = long_side(*image.shape[-2:], size) if isinstance(size, int) else tuple(size)
    if shape == tuple(image.shape[-2:]):
        return image
    return F.interpolate(image[None], size=shape, mode="bilinear", antialias=True, align_corners=False)[0].clamp(0, 1)
