"""Photos: loading (a file, or one of the photos that ship with scikit-image / scikit-learn),
resizing, and comparing (PSNR)."""
from __future__ import annotations

import importlib.util
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np
import torch
import torch.nn.functional as F
from PIL import ExifTags, Image, ImageOps
from torch import Tensor

from nsp.errors import BadInput


BUILTIN = {  # the photos that ship with scikit-image and scikit-learn: name -> (package, folder, file)
    "astronaut": ("skimage", "data", "astronaut.png"),
    "chelsea": ("skimage", "data", "chelsea.png"),
    "coffee": ("skimage", "data", "coffee.png"),
    "rocket": ("skimage", "data", "rocket.jpg"),
    "flower": ("sklearn", "datasets/images", "flower.jpg"),
    "china": ("sklearn", "datasets/images", "china.jpg"),
}


class ImageError(BadInput):
    """An ``image=`` that cannot be painted; the message names it and what is valid."""


def _builtin(name: str) -> Path:
    """Where the built-in photo ``name`` lies, found without importing its package's modules
    (scikit-image's loaders pull in scipy, about a second)."""
    package, folder, file = BUILTIN[name]
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ImageError(f"image={name} ships with {package}, which is not installed")
    return Path(spec.submodule_search_locations[0]) / folder / file


VALID = f"give a PNG/JPEG path or one of: {', '.join(BUILTIN)}"
MAX_PIXELS = 20_000 * 20_000  # photos this large still load with max_side; PIL's own guard stops at 179 M
WHITE = {"I": 65535, "F": 1.0}  # PIL keeps 16-bit samples in I modes; F is taken as [0, 1]
TURNED = (5, 6, 7, 8)  # EXIF orientations that swap width and height


def load_image(spec: str, max_side: int | None = None, key: str = "image") -> Tensor:
    """A built-in photo's name or an image file's path -> (3, H, W) float in [0, 1], as an image viewer
    shows it (upright as its EXIF says, transparent pixels over white); errors name it as ``key=spec``.

    With ``max_side``, a longer photo comes back with long side ``max_side`` (aspect kept), reduced while
    it is decoded, so the full size is never held as floats (nor, for JPEG, decoded at all).
    """
    path = _builtin(spec) if spec in BUILTIN else Path(spec).expanduser()
    if not path.is_file():
        raise ImageError(f"{key}={spec}: no such file; {VALID}")
    with _readable(f"{key}={spec}"):
        image = Image.open(path)
    with image:
        if image.width * image.height > MAX_PIXELS:
            raise ImageError(f"{key}={spec} is {image.width}×{image.height} pixels, over the limit of "
                             f"{MAX_PIXELS // 10**6} megapixels; give a smaller image")
        with _readable(f"{key}={spec}"):
            return _decode(image, max_side)


@contextmanager
def _readable(given: str) -> Iterator[None]:
    """PIL's errors while reading the image ``given`` (``key=spec``) -> one-line ImageErrors; PIL's size
    guard, a module global, is lifted meanwhile (load_image checks the size itself)."""
    guard, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None
    try:
        yield
    except (OSError, ValueError, SyntaxError) as error:
        raise ImageError(f"{given} is not an image this can read ({error}); {VALID}") from None
    finally:
        Image.MAX_IMAGE_PIXELS = guard


def _decode(image: Image.Image, max_side: int | None) -> Tensor:
    """An opened, not yet loaded PIL image -> (3, H, W) float in [0, 1], long side at most ``max_side``."""
    width, height = image.size
    shrink = max_side is not None and max(width, height) > max_side
    if shrink:
        height, width = long_side(height, width, max_side)
        image.draft(None, (width, height))  # JPEG only: decode at 1/2, 1/4 or 1/8 scale, never below this
    if image.getexif().get(ExifTags.Base.Orientation) in TURNED:
        width, height = height, width
    ImageOps.exif_transpose(image, in_place=True)
    image = _resizable(image)
    if shrink:
        image = image.resize((width, height), Image.Resampling.LANCZOS, reducing_gap=3.0)
    return _tensor(image)


def _resizable(image: Image.Image) -> Image.Image:
    """Any PIL image -> the same picture in a mode PIL resamples well: L, LA, RGB, RGBA, I or F."""
    if image.mode in WHITE or (image.mode in ("L", "LA", "RGB", "RGBA") and "transparency" not in image.info):
        return image
    if image.mode.startswith("I;16"):  # PIL cannot reduce these
        return image.convert("I")
    return image.convert("RGBA" if image.has_transparency_data else "RGB")  # palette, CMYK, 1-bit, ...


def _tensor(image: Image.Image) -> Tensor:
    """A PIL image in L, LA, RGB, RGBA, I or F -> (3, H, W) float in [0, 1], alpha over white."""
    if image.mode in ("LA", "RGBA"):
        white = Image.new("RGBA", image.size, "white")
        image = Image.alpha_composite(white, image.convert("RGBA")).convert("RGB")
    pixels = torch.from_numpy(np.array(image))  # (H, W, 3) or (H, W)
    photo = torch.empty(3, image.height, image.width)  # one float copy, whatever the samples' type
    photo.copy_(pixels.permute(2, 0, 1) if pixels.ndim == 3 else pixels)
    return photo.div_(WHITE.get(image.mode, 255)).clamp_(0, 1)


# Pixel arrays (nsp.paint from Python): what each dtype's values mean, read by the dtype, never guessed from the values.
LAYOUTS = "(H, W), (H, W, C), (C, H, W) or (1, C, H, W), C = 1, 2, 3 or 4 (grey, grey + alpha, RGB, RGBA)"
DTYPES = "uint8 (0–255), uint16 (0–65535), other integers (0–255), bool, or floats in [0, 1]"
CHANNELS = (1, 2, 3, 4)
SLACK = 0.1  # floats this far outside [0, 1] (a resampling's overshoot) are clamped; farther are refused


def from_pil(image: Image.Image) -> Tensor:
    """A PIL image -> (3, H, W) float in [0, 1], as :func:`load_image` reads a file: upright as its
    EXIF orientation says, 16-bit at its true brightness, transparent pixels over white."""
    with _readable("image"):
        return _tensor(_resizable(ImageOps.exif_transpose(image)))


def from_array(pixels: np.ndarray | Tensor, key: str = "image") -> Tensor:
    """A numpy array or torch tensor -> (3, H, W) float32 in [0, 1], alpha over white.

    Layouts: :data:`LAYOUTS`; where both ends could be channels ((3, H, 4)), a tensor is read channels
    first, an array channels last. Values by dtype (:data:`DTYPES`); outside its range, or not finite,
    they are refused (:class:`ImageError` naming ``key``), not rescaled.
    """
    tensor = isinstance(pixels, Tensor)
    if tensor:
        pixels = pixels.detach().cpu()
        pixels = pixels.float() if pixels.dtype == torch.bfloat16 else pixels  # numpy has no bfloat16
    pixels = np.asarray(pixels)
    shape = tuple(pixels.shape)
    if pixels.ndim == 4 and shape[0] == 1:
        pixels = pixels[0]
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    elif pixels.ndim == 3 and pixels.shape[0] in CHANNELS and (tensor or pixels.shape[-1] not in CHANNELS):
        pixels = pixels.transpose(1, 2, 0)
    if pixels.ndim != 3 or pixels.shape[-1] not in CHANNELS or 0 in pixels.shape:
        raise ImageError(f"{key}: an array of shape {shape} is not a picture; expected {LAYOUTS}")
    values = torch.from_numpy(_unit(pixels, key))  # (H, W, C)
    if values.shape[-1] in (2, 4):  # alpha over white
        values = values[..., :-1] * values[..., -1:] + (1 - values[..., -1:])
    return values.expand(*values.shape[:2], 3).permute(2, 0, 1).contiguous()


def _unit(pixels: np.ndarray, key: str) -> np.ndarray:
    """(H, W, C) pixels of any dtype -> float32 in [0, 1], read as :data:`DTYPES` says."""
    kind = pixels.dtype.kind
    if kind == "b":
        return pixels.astype(np.float32)
    if kind not in "uif":
        raise ImageError(f"{key}: {pixels.dtype} values are not pixels; expected {DTYPES}")
    if kind == "f" and not np.isfinite(pixels).all():
        raise ImageError(f"{key}: its {pixels.dtype} values include NaN or infinity; expected {DTYPES}")
    low, high = pixels.min().item(), pixels.max().item()
    if kind == "f":
        if low < -SLACK or high > 1 + SLACK:
            raise ImageError(f"{key}: {pixels.dtype} values from {low:g} to {high:g}; floats are read in [0, 1] "
                             "(0 black, 1 white): divide 8-bit values by 255, 16-bit ones by 65535")
        return pixels.astype(np.float32).clip(0, 1)
    white = 65535 if pixels.dtype == np.uint16 else 255
    if low < 0 or high > white:
        raise ImageError(f"{key}: {pixels.dtype} values from {low} to {high}, outside 0–{white}; expected {DTYPES} "
                         "(16-bit values as uint16)")
    return pixels.astype(np.float32) / white


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


def psnr(a: Tensor, b: Tensor) -> Tensor:
    """PSNR in dB of images in [0, 1], (…, C, H, W) pairs -> (…,)."""
    return -10 * torch.log10(((a - b) ** 2).mean((-3, -2, -1)).clamp_min(1e-10))


def ssim(a: Tensor, b: Tensor, sigma: float = 1.5) -> Tensor:
    """SSIM of images in [0, 1], (C, H, W) pairs -> (), as Wang et al. and ``skimage`` with
    ``gaussian_weights`` (window σ, radius ⌊3.5σ + 0.5⌋, population covariances), averaged over channels
    and the pixels whose window lies inside the image; a window wider than the image is cut to it (skimage
    refuses). Written here: skimage's import (scipy) costs a painting 0.2–0.3 s, torchmetrics' seconds."""
    radius = min(int(3.5 * sigma + 0.5), (min(a.shape[-2:]) - 1) // 2)
    g = torch.exp(-0.5 * (torch.arange(-radius, radius + 1, dtype=a.dtype, device=a.device) / sigma) ** 2)
    g, channels = g / g.sum(), a.shape[0]
    stack = torch.stack([a, b, a * a, b * b, a * b]).reshape(1, 5 * channels, *a.shape[-2:])
    window = g.expand(5 * channels, 1, 1, -1)
    mean = F.conv2d(F.conv2d(stack, window, groups=5 * channels), window.transpose(-1, -2), groups=5 * channels)
    mu_a, mu_b, aa, bb, ab = mean.reshape(5, channels, *mean.shape[-2:])
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    var_a, var_b, cov = aa - mu_a ** 2, bb - mu_b ** 2, ab - mu_a * mu_b
    return ((2 * mu_a * mu_b + c1) * (2 * cov + c2) / ((mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))).mean()
