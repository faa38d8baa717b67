"""The batched vector engine: B strokes of one brush -> (foreground, alpha) at any resolution.

The canvas is cut into tiles. A stroke is evaluated only on the tiles it can touch — first its
bounding box, then the brush's distance bound at each tile centre, coarse to fine on large
canvases — and the (stroke, tile) pairs are shaded together in a few large passes, so a stroke
costs only the pixels near it and no Python loop runs over strokes.
"""
from __future__ import annotations

import ctypes
import functools
import math
from dataclasses import dataclass

import torch
from torch import Tensor

from nsp.brushes.base import Brush
from nsp.brushes.noise import stroke_keys
from nsp.engine.fused import choose, fused, prepare
from nsp.engine.kernels import near_tiles, shade_tiles, shade_any_size, shade_any_size_grad, tile_offsets

PASS_PIXELS = 1 << 18  # pixels shaded per pass of the inner loop


def _eager(stage, brush: Brush, paired: tuple, fixed: tuple, **consts):  # what fused() computes compiled
    return stage(brush, *paired, *fixed, **consts)


@dataclass
class Tiles:
    """Strokes rasterized sparsely: the (stroke, tile) pairs (P,) they touch, their pixels' foreground
    ``fg`` (P, 3, tile²) and ``alpha`` (P, tile²), the tiling ``rows``×``cols``, and the pairs in
    ``layers`` (their sizes, summing to P). A pair's layer is its rank among its tile's pairs, in
    stroke order; sorted by layer, a layer touches each tile once, so blending the layers in order
    paints every tile's strokes in order."""

    stroke: Tensor
    tile: Tensor
    fg: Tensor
    alpha: Tensor
    layers: list[int]
    rows: int
    cols: int

    def between(self, first: int, last: int) -> "Tiles":
        """The pairs of strokes first, …, last − 1 alone (numbered from 0), in layers of their own."""
        keep = ((self.stroke >= first) & (self.stroke < last)).nonzero()[:, 0]
        order, layers = in_layers(self.tile[keep])  # a tile's pairs, in layer order, are in stroke order
        keep = keep[order]
        return Tiles(self.stroke[keep] - first, self.tile[keep], self.fg[keep], self.alpha[keep], layers, self.rows,
                     self.cols)


def in_layers(tile: Tensor) -> tuple[Tensor, list[int]]:
    """The order (P,) sorting pairs, given in stroke order, into layers (:class:`Tiles`), and the layers' sizes."""
    by_tile = torch.argsort(tile, stable=True)  # stable: each tile's strokes stay in order
    tile_sorted = tile[by_tile]
    rank = torch.arange(len(tile), device=tile.device) - torch.searchsorted(tile_sorted, tile_sorted)
    return by_tile[torch.argsort(rank, stable=True)], (torch.bincount(rank).tolist() if len(rank) else [])


def to_tiles(image: Tensor, tile: int) -> Tensor:
    """(..., C, H, W) image -> (..., rows·cols, C, tile²) tiles, zero-padded to whole tiles; inverse of :func:`untile`."""
    *lead, c, height, width = image.shape
    rows, cols, n = math.ceil(height / tile), math.ceil(width / tile), len(lead)
    padded = torch.nn.functional.pad(image, (0, cols * tile - width, 0, rows * tile - height))
    tiles = padded.reshape(*lead, c, rows, tile, cols, tile).permute(*range(n), n + 1, n + 3, n, n + 2, n + 4)
    return tiles.reshape(*lead, rows * cols, c, tile * tile)


def untile(tiles: Tensor, height: int, width: int, tile: int) -> Tensor:
    """(..., rows·cols, C, tile²) tiles -> (..., C, height, width) image; inverse of :func:`to_tiles`."""
    rows, cols = math.ceil(height / tile), math.ceil(width / tile)
    lead, c, n = tiles.shape[:-3], tiles.shape[-2], tiles.dim() - 3
    image = tiles.reshape(*lead, rows, cols, c, tile, tile).permute(*range(n), n + 2, n, n + 3, n + 1, n + 4)
    return image.reshape(*lead, c, rows * tile, cols * tile)[..., :height, :width]


def boxed_tiles(box: Tensor, height: int, width: int, tile: int, margin: float) -> Tensor:
    """(B, rows·cols) mask of the tiles that meet each stroke's box (B, 4) grown by ``margin`` px."""
    rows, cols = math.ceil(height / tile), math.ceil(width / tile)
    r = torch.arange(rows, device=box.device)[None, :, None]
    c = torch.arange(cols, device=box.device)[None, None, :]
    return in_box(box[:, None, None], r, c, tile, margin).reshape(len(box), rows * cols)


def in_box(box: Tensor, row: Tensor, col: Tensor, tile: int, margin: float) -> Tensor:
    """Whether tile (row, col) meets the box (..., 4) grown by ``margin`` px; all broadcast."""
    lo, hi = ((box - margin) / tile).floor(), ((box + margin) / tile).floor()
    return ((col >= lo[..., 0]) & (col <= hi[..., 2])) & ((row >= lo[..., 1]) & (row <= hi[..., 3]))  # one full-size &


def subtiles(b: Tensor, t: Tensor, box: Tensor, height: int, width: int, coarse: int, fine: int,
             margin: float) -> tuple[Tensor, Tensor]:
    """The (stroke, tile) pairs of the ``fine`` tiles inside each ``coarse`` tile t that meet the
    stroke's box (B, 4) grown by ``margin`` px: (≤ P·k²,) each, k = coarse / fine."""
    k = coarse // fine
    cols, fine_rows, fine_cols = math.ceil(width / coarse), math.ceil(height / fine), math.ceil(width / fine)
    offset = torch.arange(k, device=t.device)
    row = (torch.div(t, cols, rounding_mode="floor") * k)[:, None, None] + offset[None, :, None]  # (P, k, 1)
    col = (t % cols * k)[:, None, None] + offset[None, None, :]  # (P, 1, k)
    inside = ((row < fine_rows) & (col < fine_cols) & in_box(box[b][:, None, None], row, col, fine, margin)).flatten(1)
    return b[:, None].expand_as(inside)[inside], (row * fine_cols + col).flatten(1)[inside]


def rasterize(brush: Brush, x: Tensor, height: int, width: int, *, softness: float | None = None, tile: int = 8,
              compile: bool | None = False, first: int = 0) -> Tiles:
    """Evaluate strokes ``x`` (B, d), numbers ``first``, … of their painting, on the tiles of a
    ``height``×``width`` canvas they touch, culled by box, then by distance bound at tile centres.
    ``compile`` (as :func:`render`'s) culls and shades by the brush's compiled kernels; where one
    kernel serves every canvas of this detail (:meth:`~nsp.brushes.Brush.sized`), it culls eagerly
    and shades by it, differentiably (:class:`AnySizeShade`)."""
    margin = 1.0 if softness is None else 12.0 * softness  # where coverage is still non-zero
    build = compile is True  # auto compiles nothing
    compile = choose(compile, brush, x, height, width, softness, tile)
    run = functools.partial(fused, build=build) if compile and brush.sized(width) is None else _eager
    with torch.no_grad():
        # Coarse to fine: on a canvas 32 tiles wide or more, tiles 4×, 16×, … as wide are culled first.
        sizes = [tile]
        while sizes[-1] * 32 <= max(height, width):
            sizes.append(sizes[-1] * 4)
        box = brush.extent(x.detach(), height, width)  # (B, 4) px
        b, t = boxed_tiles(box, height, width, sizes[-1], margin).nonzero(as_tuple=True)
        coarse = None
        for size in reversed(sizes):
            if coarse is not None:
                b, t = subtiles(b, t, box, height, width, coarse, size, margin)
            keep = run(near_tiles, brush, (x.detach()[b], t), (), height=height, width=width, tile=size, margin=margin)
            b, t, coarse = b[keep], t[keep], size
        order, layers = in_layers(t)  # b, in stroke order, stays so in each tile
        b, t = b[order], t[order]

    fg, alpha = _shade(brush, x, b, t, height, width, tile, softness, compile, build, first)
    return Tiles(b, t, fg, alpha, layers, math.ceil(height / tile), math.ceil(width / tile))


def _shade(brush: Brush, x: Tensor, b: Tensor, t: Tensor, height: int, width: int, tile: int, softness: float | None,
           compile: bool, build: bool, first: int = 0) -> tuple[Tensor, Tensor]:
    """Foreground (P, 3, tile²) and alpha (P, tile²) of pairs (b, t) (P,) of strokes x (B, d), numbers ``first``, …:
    by the compiled kernels where ``compile`` (:func:`~nsp.engine.fused.choose`) and ready, else eagerly."""
    # x.index_select, not x[b]: its gradient sums a stroke's pairs in one order (x[b]'s, with 2 threads, in any).
    dx, dy = tile_offsets(tile, x)
    varies = brush.varies(width)  # where it does not, key is t: an int64 a pair, unread
    key = stroke_keys(brush.seed, torch.arange(first, first + len(x), device=x.device))[b] if varies else t
    xs = x.index_select(0, b)
    sized = brush.sized(width) if compile else None
    shade = _eager
    if sized is not None:
        canvas = torch.tensor([height, width], dtype=x.dtype, device=x.device)
        if prepare(shade_any_size, sized, (xs.detach(), t, key), (dx, dy, canvas), build=build, tile=tile,
                   softness=softness):
            shade = (lambda stage, brush, paired, fixed, **consts:
                     AnySizeShade.apply(*paired, *fixed, canvas, sized, consts["tile"], consts["softness"], build))
    elif compile and prepare(shade_tiles, brush, (xs.detach(), t, key), (dx, dy), build=build, height=height,
                             width=width, tile=tile, softness=softness):
        shade = functools.partial(fused, build=build)
    # An eager pass shades at most PASS_PIXELS pixels, so the allocator recycles its temporaries instead of the
    # system page-faulting them in for every op; a compiled kernel keeps none: it shades every pair at once.
    step = max(1, len(b) if shade is not _eager else PASS_PIXELS // tile**2)
    passes = [shade(shade_tiles, brush, (xp, tp, kp), (dx, dy), height=height, width=width, tile=tile, softness=softness)
              for xp, tp, kp in zip(xs.split(step), t.split(step), key.split(step))]
    return passes[0] if len(passes) == 1 else tuple(map(torch.cat, zip(*passes)))  # split yields ≥ 1 part


def render_whole(brush: Brush, x: Tensor, size: int, *, softness: float, tile: int = 8,
                 compile: bool | None = False) -> tuple[Tensor, Tensor]:
    """Strokes x (B, d) each alone on a size² canvas in the soft mode, as :func:`render` draws them: fg
    (B, 3, size, size), alpha (B, 1, size, size), differentiable; every shape fixed by x's and nothing
    read back from the device: every tile shaded, those a stroke cannot reach (culled by :func:`rasterize`) masked."""
    margin = 12.0 * softness
    rows = cols = math.ceil(size / tile)
    b = torch.arange(len(x), device=x.device).repeat_interleave(rows * cols)  # (P,): every (stroke, tile) pair
    t = torch.arange(rows * cols, device=x.device).repeat(len(x))
    with torch.no_grad():
        near = in_box(brush.extent(x.detach(), size, size)[b], torch.div(t, cols, rounding_mode="floor"), t % cols,
                      tile, margin)
        near &= near_tiles(brush, x.detach()[b], t, height=size, width=size, tile=tile, margin=margin)
    fg, alpha = _shade(brush, x, b, t, size, size, tile, softness, choose(compile, brush, x, size, size, softness, tile),
                       compile is True)
    alpha = alpha * near[:, None]
    return tuple(untile(v.view(len(x), rows * cols, -1, tile * tile), size, size, tile) for v in (fg, alpha))


class AnySizeShade(torch.autograd.Function):
    """:func:`~nsp.engine.kernels.shade_any_size` by its compiled kernel, and its gradient by that of
    :func:`~nsp.engine.kernels.shade_any_size_grad`, which shades the pairs again and goes back through
    them in one loop: eager autograd makes a pass over memory for each of the shading's ops, twice."""

    @staticmethod
    def forward(ctx, x: Tensor, t: Tensor, key: Tensor, dx: Tensor, dy: Tensor, canvas: Tensor, brush: Brush,
                tile: int, softness: float, build: bool = True) -> tuple[Tensor, Tensor]:
        ctx.save_for_backward(x, t, key, dx, dy, canvas)
        ctx.brush, ctx.consts, ctx.build = brush, {"tile": tile, "softness": softness}, build
        return fused(shade_any_size, brush, (x, t, key), (dx, dy, canvas), build=build, **ctx.consts)

    @staticmethod
    def backward(ctx, grad_fg: Tensor | None, grad_alpha: Tensor | None):
        x, t, key, dx, dy, canvas = ctx.saved_tensors
        grad_fg = x.new_zeros(len(x), 3, len(dx)) if grad_fg is None else grad_fg
        grad_alpha = x.new_zeros(len(x), len(dx)) if grad_alpha is None else grad_alpha
        grad = fused(shade_any_size_grad, ctx.brush, (x, t, key, grad_fg, grad_alpha), (dx, dy, canvas), build=ctx.build,
                     **ctx.consts)
        return (grad,) + (None,) * 9


def pixel_lines(stroke: Tensor, tile: Tensor, channels: int, side: int, rows: int, cols: int) -> Tensor:
    """Where each pair's pixel rows go in a dense image (B, channels, rows·t, cols·t) seen as rows
    of t = ``side`` floats: (P, channels, t) row indices, for pairs as in :class:`Tiles`."""
    plane = rows * side * cols  # rows of t floats in one channel
    lines = ((stroke * channels * rows + torch.div(tile, cols, rounding_mode="floor")) * side * cols + tile % cols)[:, None]
    lines = lines + torch.arange(side, device=stroke.device) * cols  # (P, t)
    return lines[:, None] + torch.arange(channels, device=stroke.device)[:, None] * plane


def dense(values: Tensor, stroke: Tensor, tile: Tensor, strokes: int, rows: int, cols: int) -> Tensor:
    """Sparse pairs' pixels ``values`` (P, C, t²) as a new dense image (strokes, C, rows·t, cols·t),
    out of place: its gradient is the pairs' pixels of the image's, where an in-place copy into
    zeros would have autograd copy the whole image's gradient first."""
    channels, side = values.shape[1], math.isqrt(values.shape[2])
    lines = pixel_lines(stroke, tile, channels, side, rows, cols).flatten()
    image = values.new_zeros(strokes * channels * rows * side * cols, side).index_copy(0, lines, values.reshape(-1, side))
    return image.view(strokes, channels, rows * side, cols * side)


def render(brush: Brush, x: Tensor, height: int, width: int | None = None, *, softness: float | None = None,
           tile: int = 8, compile: bool | None = False, out: Tensor | None = None) -> tuple[Tensor, Tensor]:
    """Strokes x (B, d) in [0, 1], each alone on an empty ``height``×``width`` (default: square)
    canvas: foreground (B, 3, H, W) and alpha (B, 1, H, W) in [0, 1]. ``softness``: None for the
    antialiased engine, else an edge width in pixels (the soft, differentiable mode, the painter's
    ``analytic`` renderer). ``compile``: True, by the compiled kernels, compiling those missing; None
    (auto), where this machine has them (:func:`nsp.engine.fused.choose`); False, never. ``out``: a
    (B, 4, H, W) tensor rendered into and returned views of, reused across calls (a fresh one of tens
    of megabytes costs the system's page faults every call)."""
    width = height if width is None else width
    tiles = rasterize(brush, x, height, width, softness=softness, tile=tile, compile=compile)
    rows, cols, n = tiles.rows, tiles.cols, len(x)
    if out is None and (tiles.fg.requires_grad or tiles.alpha.requires_grad):  # differentiated: the soft mode
        return tuple(dense(v, tiles.stroke, tiles.tile, n, rows, cols)[..., :height, :width]
                     for v in (tiles.fg, tiles.alpha[:, None]))
    whole = rows * tile == height and cols * tile == width
    image = clear(out) if whole and out is not None else x.new_zeros(n, 4, rows * tile, cols * tile)
    segments = image.view(-1, tile)  # rows of t floats: each pair's pixel rows are copied straight to their places
    lines = pixel_lines(tiles.stroke, tiles.tile, 4, tile, rows, cols)  # (P, 4, t)
    segments.index_copy_(0, lines[:, :3].flatten(), tiles.fg.reshape(-1, tile))
    segments.index_copy_(0, lines[:, 3].flatten(), tiles.alpha.reshape(-1, tile))
    if out is not None and not whole:
        out.copy_(image[..., :height, :width])
    elif out is None:
        out = image[..., :height, :width]
    return out[:, :3], out[:, 3:]


def clear(image: Tensor) -> Tensor:
    """Zero ``image`` in place and return it: a contiguous CPU tensor by C's ``memset``, whose streaming
    stores clear tens of megabytes faster than ``Tensor.zero_`` and leave the caches to the work around it."""
    if image.device.type == "cpu" and image.is_contiguous() and not image.requires_grad:
        ctypes.memset(image.data_ptr(), 0, image.numel() * image.element_size())
        return image
    return image.zero_()


def glazed(under: Tensor, fg: Tensor, glaze: float) -> Tensor:
    """The colour paint ``fg`` lays over ``under`` (both (..., 3, …)): fg itself where it covers
    (``glaze`` 0), fg·under where it is a glaze (1: its pigment filters what the layers under it let
    through, so overlaps darken), fg·(1 − glaze + glaze·under) between. Over white, always fg."""
    return fg if not glaze else fg * (1 - glaze + glaze * under)


def composite(fg: Tensor, alpha: Tensor, canvas: Tensor, glaze: float = 0.0) -> Tensor:
    """Soft blending h_i = α_i·s_i + (1 − α_i)·h_{i−1} over an ordered stroke list: foregrounds
    ``fg`` (..., N, 3, H, W), first stroke painted first, laid as s_i = :func:`glazed` (h_{i−1}, fg_i,
    ``glaze``), and ``alpha`` (..., N, 1, H, W) over the background h_0 ``canvas`` (..., 3, H, W; it
    may broadcast against fg's leading dims) -> h_N (..., 3, H, W), differentiable in all three (:class:`Blend`)."""
    return Blend.apply(fg, alpha, canvas, glaze)


class Blend(torch.autograd.Function):
    """:func:`composite`, one lerp a stroke, with its gradients written out: autograd through the
    closed form h_N = Π(1−α_j)·h_0 + Σ α_i·s_i·Π_{j>i}(1−α_j) differentiates a cumulative product
    with zeros in it (opaque pixels), 4–5× the time of these N steps, forward and backward."""

    @staticmethod
    def forward(ctx, fg: Tensor, alpha: Tensor, canvas: Tensor, glaze: float) -> Tensor:
        ctx.save_for_backward(fg, alpha, canvas)
        ctx.glaze = glaze
        h = canvas
        for i in range(fg.shape[-4]):
            h = torch.lerp(h, glazed(h, fg[..., i, :, :, :], glaze), alpha[..., i, :, :, :])
        return h

    @staticmethod
    def backward(ctx, grad: Tensor) -> tuple[Tensor, Tensor, Tensor | None, None]:
        """With g_i = ∂L/∂h_i: ∂L/∂fg_i = g_i·α_i·(1 − γ + γ·h_{i−1}), ∂L/∂α_i = Σ_channels g_i·(s_i − h_{i−1}),
        g_{i−1} = g_i·(1 − α_i + α_i·γ·fg_i) (γ: the glaze); the states h_{i−1} are blended again, not kept
        from forward."""
        fg, alpha, canvas = ctx.saved_tensors
        glaze, before = ctx.glaze, [canvas]  # h_0 … h_{N−1}
        for i in range(fg.shape[-4] - 1):
            before.append(torch.lerp(before[-1], glazed(before[-1], fg[..., i, :, :, :], glaze), alpha[..., i, :, :, :]))
        grad_fg, grad_alpha = torch.empty_like(fg), torch.empty_like(alpha)
        for i in reversed(range(fg.shape[-4])):
            a, f = alpha[..., i, :, :, :], fg[..., i, :, :, :]
            torch.mul(grad, a if not glaze else a * (1 - glaze + glaze * before[i]), out=grad_fg[..., i, :, :, :])
            torch.sum(grad * (glazed(before[i], f, glaze) - before[i]), -3, keepdim=True, out=grad_alpha[..., i, :, :, :])
            grad = grad * (1 - a) if not glaze else grad * (1 - a + a * glaze * f)
        return grad_fg, grad_alpha, grad.sum_to_size(canvas.shape) if ctx.needs_input_grad[2] else None, None


def composite_tiles(canvas: Tensor, tile: Tensor, fg: Tensor, alpha: Tensor, sizes: list[int], glaze: float = 0.0,
                    before: list | None = None, laid: list | None = None) -> Tensor:
    """Blend sparse strokes, pairs sorted in layers of ``sizes`` as in :class:`Tiles` (fg (P, 3, n),
    alpha (P, n), on tiles ``tile`` (P,)), onto the tiled ``canvas`` (T, 3, n) in stroke order, in place
    (autograd follows: no op saves the canvas itself), a layer at a time, not a stroke; returns it.
    ``glaze``: as :func:`composite`'s. ``before``, if given, gets each layer's tiles as they were under
    it; ``laid``, the colour each layer laid (:func:`glazed`)."""
    for t, f, a in _layers(tile, fg, alpha, sizes):
        under = canvas.index_select(0, t)
        if before is not None:
            before.append(under)
        f = glazed(under, f, glaze)
        if laid is not None:
            laid.append(f)
        canvas.index_copy_(0, t, torch.lerp(under, f, a))  # α·s + (1 − α)·h
    return canvas


def _layers(tile: Tensor, fg: Tensor, alpha: Tensor, sizes: list[int]):
    """Each layer's tiles (L,), foreground (L, 3, n) and alpha (L, 1, n), of pairs sorted in layers."""
    return zip(tile.split(sizes), fg.split(sizes), alpha[:, None].split(sizes))


def _block_tiles(brush: Brush, x: Tensor, block: Tensor, height: int, width: int, softness: float, tile: int,
                 compile: bool | None) -> tuple[Tiles, Tensor, int]:
    """Strokes x (N, d) shaded in the soft mode on the tiles of their blocks (``block`` (N,), each
    ``height``×``width`` px): their :class:`Tiles`, each pair's tile among all the blocks' (P,), and the tiles a block."""
    tiles = rasterize(brush, x, height, width, softness=softness, tile=tile, compile=compile)
    per_block = tiles.rows * tiles.cols
    return tiles, block[tiles.stroke] * per_block + tiles.tile, per_block


def composite_blocks(brush: Brush, x: Tensor, block: Tensor, under: Tensor, *, softness: float, tile: int = 8,
                     compile: bool | None = False, opacity: Tensor | None = None) -> Tensor:
    """Strokes x (N, d), in painting order, each painted in the soft mode over its block's
    background: ``block`` (N,) indexes ``under`` (B, 3, h, w); returns the blocks (B, 3, h, w),
    differentiable in x, under and ``opacity`` (N,; None: 1), which scales each stroke's alpha. What
    :func:`render` and :func:`composite` give together, but only the tiles each stroke touches are
    shaded and blended (:class:`TileBlend`)."""
    blocks, _, height, width = under.shape
    tiles, where, per_block = _block_tiles(brush, x, block, height, width, softness, tile, compile)
    by_stroke = torch.argsort(tiles.stroke, stable=True)  # rasterize's pairs are in its layers; blending needs stroke order
    where = where[by_stroke]
    order, layers = in_layers(where)
    pairs = by_stroke[order]
    canvas = to_tiles(under, tile).reshape(blocks * per_block, 3, tile * tile)
    alpha = tiles.alpha.index_select(0, pairs)
    if opacity is not None:
        alpha = alpha * opacity.index_select(0, tiles.stroke.index_select(0, pairs))[:, None]
    out = TileBlend.apply(tiles.fg.index_select(0, pairs), alpha, canvas, where[order], layers, brush.glaze)
    return untile(out.view(blocks, per_block, 3, tile * tile), height, width, tile)


def paint_gains(brush: Brush, x: Tensor, block: Tensor, canvas: Tensor, goal: Tensor, weights: Tensor, *,
                softness: float, tile: int = 8, compile: bool | None = False) -> Tensor:
    """How much each stroke x (N, d), painted alone in the soft mode over its block's ``canvas``,
    lowers the block's error Σ weights·|canvas − goal|: (N,). ``block`` (N,) indexes canvas and
    goal (B, 3, s, s) and weights (B, 1, s, s). Only the tiles a stroke touches are scored, where
    :func:`render` would make a full image of each."""
    blocks, _, size, _ = canvas.shape
    tiles, where, per_block = _block_tiles(brush, x, block, size, size, softness, tile, compile)
    under, aim, weight = (to_tiles(image, tile).reshape(blocks * per_block, -1, tile * tile).index_select(0, where)
                          for image in (canvas, goal, weights))
    painted = torch.lerp(under, glazed(under, tiles.fg, brush.glaze), tiles.alpha[:, None])
    gain = (((under - aim).abs() - (painted - aim).abs()) * weight).sum((1, 2))
    return gain.new_zeros(len(x)).index_add_(0, tiles.stroke, gain)


class TileBlend(torch.autograd.Function):
    """:func:`composite_tiles` out of place, with its gradients written out as :class:`Blend`'s, on
    the pairs' pixels alone: fg (P, 3, n), alpha (P, n) over the tiled canvas (T, 3, n), pair p on
    tile ``tile[p]``, the pairs sorted in ``layers``, laid with ``glaze``."""

    @staticmethod
    def forward(ctx, fg: Tensor, alpha: Tensor, canvas: Tensor, tile: Tensor, layers: list[int], glaze: float) -> Tensor:
        before = []  # each layer's tiles as they were under it (a pair's pixels: as small as fg)
        out = composite_tiles(canvas.clone(), tile, fg, alpha, layers, glaze, before)
        ctx.save_for_backward(fg, alpha, tile, *before)
        ctx.layers, ctx.glaze = layers, glaze
        return out

    @staticmethod
    def backward(ctx, grad: Tensor) -> tuple[Tensor, Tensor, Tensor, None, None, None]:
        """The layers are run back over the tiles each was blended onto, as :meth:`Blend.backward`."""
        fg, alpha, tile, *before = ctx.saved_tensors
        grad, grad_fg, grad_alpha, glaze = grad.clone(), [], [], ctx.glaze
        for (t, f, a), under in reversed(list(zip(_layers(tile, fg, alpha, ctx.layers), before))):
            g = grad.index_select(0, t)
            grad_fg.append(g * a if not glaze else g * a * (1 - glaze + glaze * under))
            grad_alpha.append((g * (glazed(under, f, glaze) - under)).sum(1))
            grad.index_copy_(0, t, g * (1 - a) if not glaze else g * (1 - a + a * glaze * f))
        return torch.cat([fg[:0], *grad_fg[::-1]]), torch.cat([alpha[:0], *grad_alpha[::-1]]), grad, None, None, None
