"""Memory a render needs, checked against what the machine has before any pixel is allocated, so a
too-large ``size`` fails at once with a size that fits instead of swapping for minutes and crashing.

A render's peak is the canvas itself (a few float copies of it) plus the stroke tiles of the largest
chunk :func:`~nsp.engine.canvas.chunks` composites at once (:data:`~nsp.engine.canvas.CHUNK_PIXELS`).
"""
from __future__ import annotations

import numbers

import psutil
from torch import Tensor

from nsp.brushes.base import Brush
from nsp.engine.canvas import CHUNK_PIXELS, chunks
from nsp.errors import BadInput
from nsp.text import shown

# Peak RSS over the pre-render baseline (ru_maxrss) of write_painting on the CPU:
CANVAS_BYTES = 37  # per canvas pixel, no strokes: PNG 38.5, 36.6, 36.1 B/px at 1000, 2000, 4000 px; GIF 25–26
TILE_BYTES = 25  # per pixel of the largest chunk's stroke boxes: 19–24 B, 500-stroke PNGs at 1000–2000 px
FRAME_BYTES = 2.5  # per pixel and GIF frame kept until the file is written: 51 frames added 118 B/px at 1000 px
TYPICAL_COVER = 25.0  # stroke_cover of those paintings (the painter's default progressive schedule): 13–25
# Peak RSS per pixel of the painter's own canvases (`python -m nsp.paint`):
WORK_BYTES = 80  # per work_size pixel: 0.91, 1.02, 1.23 GB at work_size=256, 1024, 2048 (70 B/px)
STYLE_BYTES = 5000  # per style.size pixel of the photo in full mode (VGG-19 features, their gradients): 4.4–4.8 kB
BATCH_BYTES = 300  # per pixel of each stroke of a batch trained on the CPU (`python -m nsp.train`, 32 px)
SET_BYTES = 16  # per pixel of each held-out stroke: its foreground and alpha, float32
# Estimated: an SVG of a brush whose paint has no vector form holds each stroke's paint as an image,
IMAGE_BYTES = 20  # per pixel of every stroke's box: its colour and alpha kept as float32 till encoded (16 B), a PNG of it
MIN_SIDE, MAX_SIDE = 16, 10**9  # a render's long side, in pixels: smaller shows nothing, larger fits no machine


class MemoryLimit(BadInput):
    """A render larger than the memory available; the message names the largest size that fits."""


def available_bytes() -> int:
    """Bytes of memory the system can hand out now without swapping (on Linux, MemAvailable)."""
    return psutil.virtual_memory().available


def check_side(size: object, key: str = "size") -> int:
    """``size``, a render's long side, as an int; :class:`BadInput` naming ``key`` for one that is not
    an integer from :data:`MIN_SIDE` to :data:`MAX_SIDE` (a bool, a float, a string are refused)."""
    if not isinstance(size, numbers.Integral) or isinstance(size, bool) or not MIN_SIDE <= size <= MAX_SIDE:
        value = "an integer of over 39 digits" if isinstance(size, numbers.Integral) and abs(size) >= 10**39 else shown(size)
        raise BadInput(f"{key}={value}: expected a whole number of pixels from {MIN_SIDE} to {MAX_SIDE}")
    return int(size)


def check_render(brush: Brush, strokes: Tensor, height: int, width: int, suffix: str = ".png", key: str = "size",
                 frames: int = 0) -> None:
    """Raise :class:`MemoryLimit` if strokes (N, d) written as a ``height``×``width`` ``suffix`` file
    (.png, .gif with ``frames`` frames, .svg) will not fit in memory. An SVG holds no pixels, except of
    a brush whose paint has no vector form (``svg_painted``), each stroke's kept as an image till encoded."""
    if suffix == ".svg" and not brush.svg_painted:
        return  # its elements are text, whatever the size
    cover = stroke_cover(brush, strokes, height, width)
    images = 0.0
    if suffix == ".svg" and len(strokes):
        images = IMAGE_BYTES * float(brush.box_area(strokes, height, width).sum()) / (height * width)
    check_canvas(height, width, key, cover, frames=frames, pixel_bytes=CANVAS_BYTES + images)


def stroke_cover(brush: Brush, strokes: Tensor, height: int, width: int) -> float:
    """How many canvases the bounding boxes of the largest chunk of strokes (N, d) that
    :func:`paint_canvas` composites at once cover, on a ``height``×``width`` canvas (0 for N = 0)."""
    area = brush.box_area(strokes, height, width).split([len(part) for part in chunks(brush, strokes, height, width)])
    return max((float(a.sum()) for a in area), default=0.0) / (height * width)


def check_canvas(height: int, width: int, key: str, cover: float = TYPICAL_COVER, frames: int = 0,
                 pixel_bytes: float = CANVAS_BYTES, noun: str = "render") -> None:
    """Raise :class:`MemoryLimit` if a ``height``×``width`` render (pixels) will not fit in memory.

    Args:
        key: the option that set its long side (``size``, ``render_size``), named in the message.
        cover: canvases covered by the largest chunk of strokes (:func:`stroke_cover`); the default
            is a typical painting's, for checks made before the strokes exist.
        frames: GIF frames the render holds at once (0 for a still image).
        pixel_bytes: bytes per canvas pixel besides the strokes' tiles and the frames
            (:data:`WORK_BYTES`, :data:`STYLE_BYTES` for the painter's own canvases).
        noun: what the message calls it.
    """
    cover = min(cover, max(1.0, CHUNK_PIXELS / (height * width)))  # chunks hold at most CHUNK_PIXELS, or a stroke
    need = (pixel_bytes + TILE_BYTES * cover + FRAME_BYTES * frames) * height * width
    _check(need, key, max(height, width), 2, f"a {width}×{height} {noun}")


def check_training(batch_size: int, held_out: int, size: int, on_cpu: bool) -> None:
    """Raise :class:`MemoryLimit` naming ``data.batch_size`` if training on ``size``-px strokes, a
    batch at a time, with ``held_out`` validation and test strokes kept, will not fit in memory
    (a batch's activations count only where training runs on the CPU)."""
    batch = batch_size * size * size * (BATCH_BYTES if on_cpu else SET_BYTES)
    held = held_out * size * size * SET_BYTES
    if held > available_bytes():
        raise MemoryLimit(f"data.val_size + data.test_size = {held_out}: keeping that many {size}-px strokes needs about "
                          f"{held / 1e9:.1f} GB, {available_bytes() / 1e9:.1f} GB is available; keep their sum under "
                          f"about {_two_digits(held_out * available_bytes() / held)}")
    _check(batch + held, "data.batch_size", batch_size, 1, f"training on batches of {size}-px strokes", room=held)


def _check(need: float, key: str, value: int, power: int, what: str, room: float = 0.0) -> None:
    """Raise :class:`MemoryLimit` if ``need`` bytes exceed what is available: the message names
    ``key=value``, ``what`` needs it, and the largest value that fits, the need growing as
    ``value ** power`` over a fixed ``room``."""
    free = available_bytes()
    if need > free:
        fits = _two_digits(value * max((free - room) / (need - room), 0) ** (1 / power))
        raise MemoryLimit(f"{key}={value}: {what} needs about {need / 1e9:.1f} GB, {free / 1e9:.1f} GB is "
                          f"available; the largest that fits is about {key}={fits}")


def _two_digits(n: float) -> int:
    """``n`` rounded down to two significant digits: 15396.2 -> 15000."""
    step = 10 ** max(0, len(str(int(n))) - 2)
    return int(n) // step * step
