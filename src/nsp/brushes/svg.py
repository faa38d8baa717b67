"""A stroke's paint as an SVG image, for the brushes whose paint has no vector form."""
from __future__ import annotations

import base64
import io

import numpy as np


def image_element(left: int, top: int, image: np.ndarray) -> str:
    """A stroke's paint (h, w, 4) in [0, 1] as an embedded PNG whose first pixel lies on canvas pixel
    (left, top): a browser draws it pixel on pixel, as final.png shows it."""
    from PIL import Image

    buffer = io.BytesIO()
    # compress level 3: 2× faster than 6, 10 % larger
    Image.fromarray((image * 255 + 0.5).astype(np.uint8), "RGBA").save(buffer, format="PNG", compress_level=3)
    uri = "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()
    h, w = image.shape[:2]
    return f'<image x="{left - 0.5}" y="{top - 0.5}" width="{w}" height="{h}" href="{uri}"/>'
