"""What the brushes' SVG elements share: colours, embedded images, the unit-square frame of a
rectangle stroke."""
from __future__ import annotations

import base64
import io

import numpy as np

UNIT = 'x="-0.5" y="-0.5" width="1" height="1"'  # the unit square a rectangle stroke is drawn in


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


def rectangle_frame(p: np.ndarray, height: int, width: int) -> str:
    """The transform taking the unit square to the rectangle p[0:5] = x, y, w, h, θ, in pixels."""
    cx, cy, w, h = p[0] * (width - 1), p[1] * (height - 1), max(p[2] * width, 1e-3), max(p[3] * width, 1e-3)
    return f'transform="translate({cx:.3f} {cy:.3f}) rotate({p[4] * 180:.3f}) scale({w:.3f} {h:.3f})"'


def bezier_points(p: np.ndarray, height: int, width: int) -> np.ndarray:
    """P0, P1, P2 of p[0:6] = x0, y0, x1, y1, x2, y2 in pixels: (3, 2)."""
    return p[:6].reshape(3, 2) * [width - 1, height - 1]
