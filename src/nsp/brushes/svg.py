"""What the brushes' SVG elements share: embedded images, a Bézier stroke's control points."""
from __future__ import annotations

import base64
import io

import numpy as np

from nsp.brushes.bezier import CONTROL


def png_data_uri(image: np.ndarray) -> str:
    """An (H, W, 4) RGBA image in [0, 1] as an embedded PNG."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray((image * 255 + 0.5).astype(np.uint8), "RGBA").save(
        buffer, format="PNG", compress_level=3)  # 2× faster than 6, 10 % larger
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()


def image_element(left: int, top: int, image: np.ndarray) -> str:
    """A stroke's paint (h, w, 4) in [0, 1] as an image whose first pixel lies on canvas pixel (left, top):
    a browser draws it pixel on pixel, as final.png shows it."""
    h, w = image.shape[:2]
    return f'<image x="{left - 0.5}" y="{top - 0.5}" width="{w}" height="{h}" href="{png_data_uri(image)}"/>'


def bezier_points(p: np.ndarray, height: int, width: int) -> np.ndarray:
    """P0, P1, P2 (:data:`~nsp.brushes.bezier.CONTROL`) of one stroke's parameters p (d,) in pixels: (3, 2)."""
    return p[:len(CONTROL)].reshape(3, 2) * [width - 1, height - 1]
