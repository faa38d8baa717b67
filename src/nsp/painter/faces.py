"""Faces in the photo, found by the frontal-face cascade (local binary patterns, trained by OpenCV)
that ships with scikit-image: offline, nothing downloaded, no weights to fetch. The painter gives
each face a level of finer blocks of its own (``Painter.paint(faces=…)``): error shared over the whole
picture spends a 500-stroke budget on the flag and the suit, and paints eyes as brown bars."""
from __future__ import annotations

from functools import cache
from typing import NamedTuple

from torch import Tensor

MIN_FACE = 12  # the smallest face looked for, in pixels of the image searched
MARGIN = 0.3  # a found box grows by this share of its side: the cascade frames eyes to mouth, not the hairline and chin


class Box(NamedTuple):
    """A rectangle as fractions of the image's height (``top``, ``height``) and width (``left``, ``width``)."""

    top: float
    left: float
    height: float
    width: float


@cache
def cascade():
    """scikit-image's frontal-face cascade, loaded once; its import brings scipy (0.2–0.3 s), only
    when faces are looked for."""
    from skimage.data import lbp_frontal_face_cascade_filename
    from skimage.feature._cascade import Cascade

    return Cascade(lbp_frontal_face_cascade_filename())


def find_faces(image: Tensor) -> list[Box]:
    """The frontal faces in ``image`` (3, H, W) in [0, 1], each box grown by ``MARGIN`` and kept
    within the image; boxes that overlap are merged. Best at a 256-px working size."""
    _, height, width = image.shape
    pixels = (image.permute(1, 2, 0).clamp(0, 1) * 255).round().byte().cpu().numpy()
    side = min(height, width)
    found = cascade().detect_multi_scale(
        img=pixels, scale_factor=1.2, step_ratio=1, min_size=(MIN_FACE, MIN_FACE), max_size=(side, side))
    boxes: list[tuple[float, float, float, float]] = []  # (top, left, bottom, right) in pixels
    for face in found:
        grow_y, grow_x = face["height"] * MARGIN / 2, face["width"] * MARGIN / 2
        box = (max(0.0, face["r"] - grow_y), max(0.0, face["c"] - grow_x),
               min(height, face["r"] + face["height"] + grow_y), min(width, face["c"] + face["width"] + grow_x))
        while (hit := next((other for other in boxes if _overlap(box, other)), None)) is not None:
            boxes.remove(hit)
            box = (min(box[0], hit[0]), min(box[1], hit[1]), max(box[2], hit[2]), max(box[3], hit[3]))
        boxes.append(box)
    return [Box(top / height, left / width, (bottom - top) / height, (right - left) / width)
            for top, left, bottom, right in boxes]


def _overlap(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """Whether two (top, left, bottom, right) rectangles share any area."""
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]
