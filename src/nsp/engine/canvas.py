"""Whole paintings: an ordered stroke list composited onto a coloured canvas."""
from __future__ import annotations

import math
from typing import Iterator

import torch
from torch import Tensor

from nsp.brushes.base import Brush
from nsp.colors import parse_color
from nsp.engine.fused import pays
from nsp.engine.raster import composite_tiles, rasterize, to_tiles, untile

CHUNK_PIXELS = 1 << 24  # bounding-box pixels of the strokes rendered at once; their tiles take ~16 B a pixel
CHUNK_STROKES = 1024  # and the most strokes


def chunks(brush: Brush, strokes: Tensor, height: int, width: int, most: int = CHUNK_STROKES) -> list[Tensor]:
    """``strokes`` (N, d) cut into consecutive runs of at most ``most`` strokes whose bounding
    boxes on a ``height``×``width`` canvas hold at most :data:`CHUNK_PIXELS` pixels together (a
    larger stroke alone): what :class:`TiledCanvas` renders at once, so its memory is bounded by
    the canvas, however large the strokes."""
    total = brush.box_area(strokes, height, width).cumsum(0)
    parts, start = [], 0
    while start < len(strokes):
        before = float(total[start - 1]) if start else 0.0
        end = int(torch.searchsorted(total, torch.tensor(before + CHUNK_PIXELS, dtype=total.dtype, device=total.device),
                                     right=True))
        end = min(max(end, start + 1), start + most)
        parts.append(strokes[start:end])
        start = end
    return parts


class TiledCanvas:
    """A canvas kept as tiles (rows·cols, 3, tile²) while strokes are painted onto it, so painting
    a few strokes costs only the tiles they touch, and a region is read back without untiling the
    rest (an animation's frames)."""

    def __init__(self, canvas: Tensor, tile: int = 8):
        """``canvas``: (3, H, W) in [0, 1], the picture to paint on."""
        self.height, self.width = canvas.shape[-2:]
        self.tile = tile
        self.tiles = to_tiles(canvas, tile)  # a copy: strokes are blended into it in place

    def paint(self, brush: Brush, strokes: Tensor, *, softness: float | None = None, chunk: int = CHUNK_STROKES,
              compile: bool = False, first: int = 0) -> None:
        """Composite ``strokes`` (N, d), numbers ``first``, … of their painting, in order, a
        :func:`chunks` at a time (memory stays bounded); ``compile``: shade them on the compiled
        path (:mod:`nsp.engine.fused`)."""
        for _ in self.paint_until(brush, strokes, [len(strokes)], softness=softness, chunk=chunk, compile=compile,
                                  first=first):
            pass

    def paint_until(self, brush: Brush, strokes: Tensor, ends: list[int], *, softness: float | None = None,
                    chunk: int = CHUNK_STROKES, compile: bool = False, first: int = 0) -> Iterator[int]:
        """:meth:`paint`, pausing once strokes[:end] are on the canvas to yield ``end``, for each of
        ``ends`` (ascending, the last N): an animation's frames. Strokes are still rasterized a chunk
        at a time, not a frame at a time."""
        ends, done = iter(ends), 0
        end = next(ends, None)
        for part in chunks(brush, strokes, self.height, self.width, chunk):
            tiles = rasterize(brush, part, self.height, self.width, softness=softness, tile=self.tile, compile=compile,
                              first=first + done)
            start, stop = done, done + len(part)
            while start < stop:  # the chunk's strokes up to the next end, or to its own end
                until = min(stop, len(strokes) if end is None else end)
                whole = (start, until) == (done, stop)
                composite_tiles(tiles if whole else tiles.between(start - done, until - done), self.tiles)
                if until == end:
                    yield end
                    end = next(ends, None)
                start = until
            done = stop

    def image(self, top: int = 0, bottom: int | None = None, left: int = 0, right: int | None = None) -> Tensor:
        """The canvas, or its rows top:bottom and columns left:right: (3, h, w)."""
        bottom = self.height if bottom is None else bottom
        right = self.width if right is None else right
        t, rows, cols = self.tile, math.ceil(self.height / self.tile), math.ceil(self.width / self.tile)
        r0, c0 = top // t, left // t
        r1, c1 = math.ceil(bottom / t), math.ceil(right / t)
        part = self.tiles.view(rows, cols, 3, t * t)[r0:r1, c0:c1].reshape(-1, 3, t * t)
        image = untile(part, (r1 - r0) * t, (c1 - c0) * t, t)
        return image[:, top - r0 * t : bottom - r0 * t, left - c0 * t : right - c0 * t]


def paint_canvas(
    brush: Brush,
    strokes: Tensor,
    height: int,
    width: int,
    background: str | tuple = "white",
    *,
    softness: float | None = None,
    canvas: Tensor | None = None,
    chunk: int = CHUNK_STROKES,
    tile: int = 8,
    compile: bool | None = None,
    first: int = 0,
) -> Tensor:
    """Composite ``strokes`` (N, d), numbers ``first``, … of their painting, in order, onto a
    canvas: (3, H, W) in [0, 1].

    Only the tiles each stroke touches are rendered and blended, ``chunk`` strokes at a time, so
    a painting of thousands of strokes renders at any size in bounded memory.
    ``canvas`` (3, H, W), if given, replaces the plain ``background``. ``compile``: shade on the
    compiled path; None: where it is expected to finish sooner (:func:`nsp.engine.fused.pays`).
    """
    if canvas is None:
        color = torch.tensor(parse_color(background), dtype=strokes.dtype, device=strokes.device)
        canvas = color[:, None, None].expand(3, height, width)
    if compile is None:
        compile = pays(brush, strokes, height, width, softness)
    tiled = TiledCanvas(canvas, tile)
    tiled.paint(brush, strokes, softness=softness, chunk=chunk, compile=compile, first=first)
    return tiled.image()
