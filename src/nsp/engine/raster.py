"""The batched vector engine: B strokes of one brush -> (foreground, alpha) at any resolution.

The canvas is cut into tiles. A stroke is evaluated only on the tiles it can touch — first its
bounding box, then the brush's distance bound at each tile centre — and all (stroke, tile) pairs
are evaluated at once, so a stroke costs only the pixels near it and no Python loop runs over strokes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import torch
from torch import Tensor

from nsp.brushes.base import Brush, Pixels


def antialiased(sd: Tensor) -> Tensor:
    """Box-filtered coverage of a pixel whose centre is ``sd`` pixels outside the edge."""
    return (0.5 - sd).clamp(0, 1)


def soft(sd: Tensor, softness: float = 1.0) -> Tensor:
    """Sigmoid coverage: differentiable everywhere, a ``softness``-pixel-wide edge."""
    return torch.sigmoid(-sd / softness)


@dataclass
class Tiles:
    """Strokes rasterized sparsely: the (stroke, tile) pairs they touch.

    Attributes:
        stroke, tile: (P,) indices of the pairs, sorted by stroke.
        values: (P, 4, tile²) foreground RGB and alpha of each pair's pixels.
        rows, cols: the tiling.
    """

    stroke: Tensor
    tile: Tensor
    values: Tensor
    rows: int
    cols: int



def to_tiles(image: Tensor, tile: int) -> Tensor:
    """(C, H, W) image -> (rows·cols, C, tile²) tiles, zero-padded to whole tiles."""
    c, height, width = image.shape
    rows, cols = math.ceil(height / tile), math.ceil(width / tile)
    padded = torch.nn.functional.pad(image, (0, cols * tile - width, 0, rows * tile - height))
    return padded.reshape(c, rows, tile, cols, tile).permute(1, 3, 0, 2, 4).reshape(rows * cols, c, tile * tile)


def untile(tiles: Tensor, height: int, width: int, tile: int) -> Tensor:
    """(..., rows·cols, C, tile²) tiles -> (..., C, height, width) image; inverse of :func:`to_tiles`."""
    rows, cols = math.ceil(height / tile), math.ceil(width / tile)
    lead, c, n = tiles.shape[:-3], tiles.shape[-2], tiles.dim() - 3
    image = tiles.reshape(*lead, rows, cols, c, tile, tile).permute(*range(n), n + 2, n, n + 3, n + 1, n + 4)
    return image.reshape(*lead, c, rows * tile, cols * tile)[..., :height, :width]


def rasterize(
    brush: Brush, x: Tensor, height: int, width: int, *, softness: float | None = None, tile: int = 16
) -> Tiles:
    """Evaluate strokes ``x`` (B, d) on the tiles of a ``height``×``width`` canvas they touch."""
    coverage = antialiased if softness is None else partial(soft, softness=softness)
    margin = 1.0 if softness is None else 12.0 * softness  # where coverage is still non-zero
    dev, dtype = x.device, x.dtype
    rows, cols = math.ceil(height / tile), math.ceil(width / tile)
    with torch.no_grad():
        box = brush.extent(x.detach(), width, height)  # (B, 4) px
        col_lo = ((box[:, 0] - margin) / tile).floor()
        col_hi = ((box[:, 2] + margin) / tile).floor()
        row_lo = ((box[:, 1] - margin) / tile).floor()
        row_hi = ((box[:, 3] + margin) / tile).floor()
        r = torch.arange(rows, device=dev, dtype=dtype)[None, :, None]
        c = torch.arange(cols, device=dev, dtype=dtype)[None, None, :]
        in_box = (r >= row_lo[:, None, None]) & (r <= row_hi[:, None, None])
        in_box = in_box & (c >= col_lo[:, None, None]) & (c <= col_hi[:, None, None])
        b, t = in_box.reshape(len(x), rows * cols).nonzero(as_tuple=True)
        # Second cut: the brush's 1-Lipschitz distance bound at each candidate tile's centre.
        centre = (tile - 1) / 2
        cx = (t % cols).to(dtype) * tile + centre
        cy = torch.div(t, cols, rounding_mode="floor").to(dtype) * tile + centre
        near = brush.bound(x.detach()[b], Pixels(cx[:, None], cy[:, None], width, height))[:, 0]
        keep = near <= tile / math.sqrt(2) + margin
        b, t = b[keep], t[keep]

    offs = torch.arange(tile, device=dev, dtype=dtype)
    ox = (t % cols).to(dtype) * tile
    oy = torch.div(t, cols, rounding_mode="floor").to(dtype) * tile
    px = (ox[:, None, None] + offs[None, None, :]).expand(-1, tile, tile).reshape(len(t), tile * tile)
    py = (oy[:, None, None] + offs[None, :, None]).expand(-1, tile, tile).reshape(len(t), tile * tile)
    fg, alpha = brush.paint(x[b], Pixels(px, py, width, height), coverage)  # (P, 3, N), (P, N)
    return Tiles(b, t, torch.cat([fg, alpha[:, None]], 1), rows, cols)


def render(
    brush: Brush,
    x: Tensor,
    height: int,
    width: int | None = None,
    *,
    softness: float | None = None,
    tile: int = 16,
) -> tuple[Tensor, Tensor]:
    """Render strokes on their own, each on an empty canvas.

    Args:
        brush: the brush.
        x: (B, d) stroke parameters in [0, 1].
        height, width: canvas size in pixels (width defaults to height).
        softness: ``None`` for the antialiased engine; a width in pixels for the soft,
            differentiable mode (the painter's ``analytic`` renderer).
        tile: tile side in pixels.

    Returns:
        foreground (B, 3, H, W) and alpha (B, 1, H, W), both in [0, 1].
    """
    width = height if width is None else width
    tiles = rasterize(brush, x, height, width, softness=softness, tile=tile)
    dense = x.new_zeros(len(x), tiles.rows * tiles.cols, 4, tile * tile)
    image = untile(dense.index_put((tiles.stroke, tiles.tile), tiles.values), height, width, tile)
    return image[:, :3], image[:, 3:]


def composite(fg: Tensor, alpha: Tensor, canvas: Tensor) -> Tensor:
    """Soft blending h ← α·s + (1 − α)·h over an ordered stroke list, in closed form.

    Args:
        fg: (..., N, 3, H, W) stroke foregrounds, first stroke painted first.
        alpha: (..., N, 1, H, W).
        canvas: (..., 3, H, W) the background h_0.

    Returns:
        (..., 3, H, W): h_N = Π(1−α_j)·h_0 + Σ_i α_i·s_i·Π_{j>i}(1−α_j).
    """
    keep = 1 - alpha
    # later[i] = Π_{j>i} (1 − α_j): what survives of stroke i under the strokes painted after it.
    later = torch.cat([keep[..., 1:, :, :, :], torch.ones_like(keep[..., :1, :, :, :])], -4)
    later = later.flip(-4).cumprod(-4).flip(-4)
    everything = later[..., :1, :, :, :] * keep[..., :1, :, :, :]
    return (alpha * fg * later).sum(-4) + everything[..., 0, :, :, :] * canvas


def composite_tiles(tiles: Tiles, canvas: Tensor) -> Tensor:
    """Blend sparse strokes onto a tiled canvas (rows·cols, 3, tile²), in stroke order.

    Pairs are grouped into layers by their rank among the pairs of the same tile, so one layer
    touches each tile at most once; the loop runs over layers (the deepest tile's stroke count),
    not over strokes.
    """
    order = torch.argsort(tiles.tile, stable=True)  # stable: keeps stroke order within a tile
    tile_sorted = tiles.tile[order]
    first = torch.searchsorted(tile_sorted, tile_sorted, right=False)
    rank = torch.arange(len(order), device=order.device) - first
    by_rank = torch.argsort(rank, stable=True)
    counts = torch.bincount(rank).tolist() if len(rank) else []
    start = 0
    for count in counts:
        layer = order[by_rank[start : start + count]]
        start += count
        t, v = tiles.tile[layer], tiles.values[layer]
        canvas = canvas.index_put((t,), v[:, 3:] * v[:, :3] + (1 - v[:, 3:]) * canvas[t])
    return canvas
