"""A brush is data (its parameter spec) plus its rendering (signed distance and shading) and its
formats (an SVG element per stroke, the reference implementation's stroke arrays).

Every stroke parameter lies in [0, 1]. Coordinates: x to the right, y down; a position p lands on
pixel p·(W−1) (x) or p·(H−1) (y); sizes are fractions of the canvas width W."""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import torch
from torch import Tensor


@dataclass(frozen=True)
class Pixels:
    """Pixel centres in canvas pixel units, one row per stroke: px, py (P, N); ``key`` (P, 1) int64, each
    row's stroke's key (its index and the painting's seed, for paint that varies by stroke; None: 0);
    ``height``, ``width``: the canvas's, ints or 0-d tensors (:func:`nsp.engine.kernels.shade_any_size`)."""

    px: Tensor
    py: Tensor
    height: int | Tensor
    width: int | Tensor
    key: Tensor | None = None


@dataclass(frozen=True, eq=False)
class Brush:
    """Parameter spec of one brush.

    Attributes:
        name: config name (``brush=name``).
        params: parameter names in the paper's order.
        kinds: what each parameter is (x, y, size, angle, color, alpha), for generic code that moves strokes.
        shape, color: indices of the shape and colour parameters.
        alpha: index of the transparency parameter, or ``None`` where A ≡ 1.
        reference: columns of the reference implementation's ``x_ctt`` and ``x_color`` arrays.
        softness: the soft edge's width (pixels) the painter optimizes this brush's strokes with.
        glaze: 0 for paint that covers what is under it, 1 for a glaze whose pigment multiplies it
            (:func:`nsp.engine.raster.glazed`): the engine and the painter blend its strokes so."""

    name: str
    params: tuple[str, ...]
    kinds: tuple[str, ...]
    shape: tuple[int, ...]
    color: tuple[int, ...]
    alpha: int | None = None
    description: str = ""
    texture_path: str | None = None  # the image of an oil brush's bristle texture; None: nsp's own
    seed: int = 0  # with each stroke's index, what a brush whose paint varies by stroke draws it from
    reference: tuple[int, int] = (0, 0)
    svg_painted: ClassVar[bool] = False  # its SVG holds each stroke's paint as an image (see svg_elements)
    softness: float = 0.25  # over 0.5: +0.14 to +0.26 dB for the thin and translucent brushes; oil keeps 0.5
    glaze: float = 0.0  # how far its paint filters the colours under it (overlaps darken) rather than covering them

    def plain(self) -> "Brush":
        """This brush with any detail finer than its strokes (oil's bristles) replaced by its mean:
        what the painter's own canvases need, whose blocks it samples down to its working size."""
        return self

    def sized(self, width: int) -> "Brush | None":
        """This brush shading every canvas as one ``width`` px wide, for one compiled kernel of any size
        (:func:`nsp.engine.kernels.shade_any_size`); None where the paint is sampled to each size (a texture)."""
        return self

    def varies(self, width: int) -> bool:
        """Whether this brush draws detail on a canvas ``width`` px wide that its :meth:`plain` form
        lacks, which may vary from stroke to stroke by its key (see :class:`Pixels`)."""
        return False

    @property
    def variant(self) -> str:
        """What sets this brush's rendering apart from others of its name and parameters ("" for none)."""
        return ""

    @property
    def d(self) -> int:
        """Number of parameters of one stroke."""
        return len(self.params)

    def column(self, name: str) -> int:
        """Where parameter ``name`` lies in a stroke's parameters: ``x[:, brush.column("theta")]`` is (N,)."""
        return self.params.index(name)

    def columns(self, first: str, last: str | None = None) -> slice:
        """Parameters ``first`` to ``last`` (default: ``first`` alone) of a stroke's parameters, a plain
        slice: ``x[:, brush.columns("R0", "B0")]`` is (N, 3), ``x[:, brush.columns("r0")]`` (N, 1)."""
        return slice(self.column(first), self.column(last or first) + 1)

    def sample(self, n: int, generator: torch.Generator | None = None, device=None) -> Tensor:
        """Uniform random strokes over the whole parameter space: (n, d) in [0, 1]."""
        return torch.rand(n, self.d, generator=generator, device=device)

    # --- rendering: implemented by each brush -------------------------------------------------
    def extent(self, x: Tensor, height: int, width: int) -> Tensor:
        """Bounding boxes (P, 4) of strokes ``x`` (P, d) in pixels: x_min, y_min, x_max, y_max."""
        raise NotImplementedError

    def box_area(self, x: Tensor, height: int, width: int) -> Tensor:
        """Pixels of each stroke's bounding box inside the canvas: (P,), what culling starts from."""
        box = self.extent(x.detach(), height, width)
        w = (box[:, 2].clamp(0, width) - box[:, 0].clamp(0, width)).clamp(min=0)
        h = (box[:, 3].clamp(0, height) - box[:, 1].clamp(0, height)).clamp(min=0)
        return w * h

    def bound(self, x: Tensor, pix: Pixels) -> Tensor:
        """A 1-Lipschitz lower bound (pixels) of the signed distance, for culling: (P, N)."""
        raise NotImplementedError

    def paint(self, x: Tensor, pix: Pixels, coverage) -> tuple[Tensor, Tensor]:
        """Colour (P, 3, N) and alpha (P, N) of strokes ``x`` (P, d) at the given pixels. ``coverage``
        maps a signed distance in pixels (negative inside) to [0, 1]: a box filter for antialiased
        rendering, a sigmoid for the soft, differentiable mode."""
        raise NotImplementedError

    # --- formats: implemented by each brush ---------------------------------------------------
    def svg(self, index: int, p: np.ndarray, height: int, width: int) -> tuple[str, str]:
        """(definitions, element) drawing stroke number ``index``, parameters ``p`` (d,), on a H×W canvas."""
        raise NotImplementedError

    def centreline(self, p: np.ndarray, height: int, width: int) -> list[tuple[str, float, str]]:
        """The stroke ``p`` (d,) as a pen plotter draws it on a H×W canvas: its middle line in pieces, one
        unless its width changes along it, each (SVG path data, the line's width in pixels, its ``stroke-linecap``)."""
        raise NotImplementedError

    def svg_elements(self, strokes: np.ndarray, height: int, width: int, first: int = 0) -> Iterator[tuple[str, str]]:
        """:meth:`svg` of each stroke (N, d), numbers ``first``, … of the painting, in order; none where the
        paint has no vector form (``svg_painted``: an image each, :func:`nsp.brushes.svg.image_element`)."""
        for index, p in enumerate(strokes, first):
            yield self.svg(index, p, height, width)

    def from_reference(self, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, width: int) -> tuple["Brush", np.ndarray]:
        """Strokes in the reference implementation's convention (``x_ctt`` (N, c): the shape parameters in
        this brush's order, ``x_color`` (N, k), ``x_alpha`` (N, 1), pixel sizes at canvas width ``width``)
        -> the brush that paints them and their parameters (N, d) in [0, 1]."""
        raise NotImplementedError
