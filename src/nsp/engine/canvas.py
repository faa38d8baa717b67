"""Whole paintings: an ordered stroke list composited onto a coloured canvas."""
from __future__ import annotations

import dataclasses
import math
from typing import Iterator

import torch
from torch import Tensor

from nsp.brushes.base import Brush
from nsp.colors import parse_color
from nsp.engine.raster import Tiles, composite_tiles, rasterize, to_tiles, untile

CHUNK_PIXELS = 1 << 24  # bounding-box pixels of the strokes rendered at once; their tiles take ~16 B a pixel
CHUNK_STROKES = 1024  # and the most strokes


def chunks(brush: Brush, strokes: Tensor, height: int, width: int, most: int = CHUNK_STROKES) -> list[Tensor]:
    """``strokes`` (N, d) cut into consecutive runs of at most ``most`` strokes whose bounding boxes on a
    ``height``×``width`` canvas hold at most :data:`CHUNK_PIXELS` pixels together (a larger stroke
    alone): what :class:`TiledCanvas` renders at once, so its memory is bounded however large the strokes."""
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


def box_images(brush: Brush, strokes: Tensor, tiles: Tiles, height: int, width: int) -> list[tuple[int, int, Tensor]]:
    """The ``tiles`` of ``strokes`` (n, d) on a ``height``×``width`` canvas as an image a stroke: its first
    column and row on the canvas, and its colour and alpha (h, w, 4) in [0, 1] (a view) over the canvas
    pixels of its box that its tiles cover (empty where none); elsewhere the stroke is transparent."""
    b, t, side = tiles.stroke, tiles.tile, math.isqrt(tiles.alpha.shape[1])
    n, zero = len(strokes), torch.zeros(len(strokes), dtype=torch.long, device=t.device)
    row, col = torch.div(t, tiles.cols, rounding_mode="floor"), t % tiles.cols
    r0, c0 = zero.scatter_reduce(0, b, row, "amin", include_self=False), zero.scatter_reduce(0, b, col, "amin", include_self=False)
    r1, c1 = zero.scatter_reduce(0, b, row, "amax", include_self=False), zero.scatter_reduce(0, b, col, "amax", include_self=False)
    lines, cols = ((r1 - r0 + 1) * side).where(torch.bincount(b, minlength=n) > 0, 0), (c1 - c0 + 1) * side
    areas = lines * cols  # each stroke's tiles' rectangle, in pixels
    starts = areas.cumsum(0) - areas  # in one buffer of all of them
    offsets = torch.arange(side, device=t.device)
    where = (starts[b, None] + ((row - r0[b]) * side)[:, None] * cols[b, None] + offsets.repeat_interleave(side)[None] * cols[b, None]
             + ((col - c0[b]) * side)[:, None] + offsets.repeat(side)[None])  # (P, side²): pixel k of a tile on row k // side
    pixels = torch.cat([tiles.fg, tiles.alpha[:, None]], 1).clamp(0, 1).transpose(1, 2).reshape(-1, 4)
    images = pixels.new_zeros(int(areas.sum()), 4).index_copy_(0, where.flatten(), pixels)
    box = brush.extent(strokes.detach().double(), height, width)  # (n, 4) px: x_min, y_min, x_max, y_max
    first = torch.maximum(torch.ceil(box[:, :2] - 0.5).long(), torch.stack([c0, r0], 1) * side)  # within both, and the canvas
    last = torch.minimum(torch.floor(box[:, 2:] + 0.5).long(), torch.stack([c1 + 1, r1 + 1], 1) * side - 1)
    last = torch.minimum(last, torch.tensor([width - 1, height - 1], device=last.device))
    out = []
    for (left, top), (right, bottom), image, h, w, y0, x0 in zip(first.tolist(), last.tolist(), images.split(areas.tolist()),
                                                                  lines.tolist(), cols.tolist(), (r0 * side).tolist(),
                                                                  (c0 * side).tolist()):
        image = image.view(h, w, 4)[max(top - y0, 0) : max(bottom + 1 - y0, 0), max(left - x0, 0) : max(right + 1 - x0, 0)]
        out.append((left, top, image))
    return out


class TiledCanvas:
    """A canvas kept as tiles (rows·cols, 3, tile²) while strokes are painted onto it: painting a few
    strokes costs only the tiles they touch, and a region (an animation's frame) is read back alone."""

    def __init__(self, canvas: Tensor, tile: int = 8):
        """``canvas``: (3, H, W) in [0, 1], the picture to paint on."""
        self.height, self.width, self.tile = *canvas.shape[-2:], tile
        self.tiles = to_tiles(canvas, tile)  # a copy: strokes are blended into it in place

    def paint(self, brush: Brush, strokes: Tensor, *, softness: float | None = None, chunk: int = CHUNK_STROKES,
              compile: bool | None = False, first: int = 0, images: list | None = None) -> None:
        """Composite ``strokes`` (N, d), numbers ``first``, … of their painting, in order, a :func:`chunks`
        at a time (memory stays bounded); ``compile`` as :func:`~nsp.engine.raster.render`'s; ``images``,
        if given, gets each stroke's :func:`box_images`."""
        for _ in self.paint_until(brush, strokes, [len(strokes)], softness=softness, chunk=chunk, compile=compile,
                                  first=first, images=images):
            pass

    def paint_until(self, brush: Brush, strokes: Tensor, ends: list[int], *, softness: float | None = None,
                    chunk: int = CHUNK_STROKES, compile: bool | None = False, first: int = 0,
                    images: list | None = None) -> Iterator[int]:
        """:meth:`paint`, pausing once strokes[:end] are on the canvas to yield ``end``, for each of
        ``ends`` (ascending, the last N): an animation's frames, still rasterized a chunk at a time."""
        ends, done = iter(ends), 0
        end = next(ends, None)
        for strokes_part in chunks(brush, strokes, self.height, self.width, chunk):
            tiles = rasterize(brush, strokes_part, self.height, self.width, softness=softness, tile=self.tile,
                              compile=compile, first=first + done)
            start, stop = done, done + len(strokes_part)
            while start < stop:  # the chunk's strokes up to the next end, or to its own end
                until = min(stop, len(strokes) if end is None else end)
                part = tiles if (start, until) == (done, stop) else tiles.between(start - done, until - done)
                laid = [] if images is not None and brush.glaze else None
                composite_tiles(self.tiles, part.tile, part.fg, part.alpha, part.layers, brush.glaze, laid=laid)
                if images is not None:  # a glaze's image holds what it laid over this canvas
                    part = dataclasses.replace(part, fg=torch.cat([part.fg[:0], *laid])) if laid is not None else part
                    images += box_images(brush, strokes_part[start - done : until - done], part, self.height, self.width)
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


def paint_canvas(brush: Brush, strokes: Tensor, height: int, width: int, background: str | tuple = "white", *,
                 softness: float | None = None, canvas: Tensor | None = None, chunk: int = CHUNK_STROKES, tile: int = 8,
                 compile: bool | None = None, first: int = 0, images: list | None = None) -> Tensor:
    """Composite ``strokes`` (N, d), numbers ``first``, … of their painting, in order, onto a
    canvas: (3, H, W) in [0, 1]. Only the tiles each stroke touches are rendered and blended,
    ``chunk`` strokes at a time, so any size renders in bounded memory. ``canvas`` (3, H, W), if
    given, replaces the plain ``background``; ``compile``, ``first``, ``images``: as
    :meth:`TiledCanvas.paint`'s (``images``: what an SVG holds of a brush whose paint has no vector form)."""
    if canvas is None:
        color = torch.tensor(parse_color(background), dtype=strokes.dtype, device=strokes.device)
        canvas = color[:, None, None].expand(3, height, width)
    tiled = TiledCanvas(canvas, tile)
    tiled.paint(brush, strokes, softness=softness, chunk=chunk, compile=compile, first=first, images=images)
    return tiled.image()
