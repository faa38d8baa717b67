"""A user's grayscale image as the oil brush's texture (nsp's own is :mod:`nsp.brushes.bristles`):
a path on the command line (``brush.texture=PATH``), or a PNG data URI embedded in a stroke file,
which never names a file for nsp to read."""
from __future__ import annotations

import base64
import binascii
import io
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from nsp.errors import BadInput

EMBEDDED = "data:image/png;base64,"


def load_texture(source: str | Path) -> Tensor:
    """A texture image, a path or an :data:`EMBEDDED` PNG, as (H, W) in [0, 1]; dark means no paint."""
    from PIL import Image

    text = str(source)
    inside = text.startswith(EMBEDDED)
    name = "an embedded texture" if inside else f"brush.texture={text}"
    if not inside and not Path(text).expanduser().is_file():  # a folder, a FIFO (it would block), a missing file
        raise BadInput(f"{name}: no such image file; expected a PNG/JPEG path")
    try:
        data = io.BytesIO(base64.b64decode(text[len(EMBEDDED):], validate=True)) if inside else Path(text).expanduser()
        with Image.open(data) as image:
            image = image.convert("L")
    except (OSError, ValueError, binascii.Error, Image.DecompressionBombError) as err:
        raise BadInput(f"{name} is not a readable image ({err})") from None
    return torch.from_numpy(np.asarray(image, dtype=np.float32) / 255.0)


def embedded(source: str | Path) -> str:
    """The texture at ``source`` (see :func:`load_texture`) as an :data:`EMBEDDED` PNG, 8 bits a value."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray((load_texture(source).numpy() * 255).round().astype(np.uint8), "L").save(buffer, format="PNG")
    return EMBEDDED + base64.b64encode(buffer.getvalue()).decode()
