"""The batched vector engine: B strokes of one brush -> (foreground, alpha) at any resolution.

The canvas is cut into tiles; a stroke is evaluated only on the tiles its distance bound says it
can touch, all (stroke, tile) pairs at once, so a stroke costs only the pixels near it and there is
no Python loop over strokes.
"""
from __future__ import annotations

import math
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
    coverage = antialiased if softness is None else partial(soft, softness=softness)
    margin = 1.0 if softness is None else 12.0 * softness  # where coverage is still non-zero
    batch, dev, dtype = x.shape[0], x.device, x.dtype
    nty, ntx = math.ceil(height / tile), math.ceil(width / tile)

    offs = torch.arange(tile, device=dev, dtype=dtype)
    ty, tx = torch.meshgrid(torch.arange(nty, device=dev) * tile, torch.arange(ntx, device=dev) * tile, indexing="ij")
    tx, ty = tx.reshape(-1).to(dtype), ty.reshape(-1).to(dtype)  # (T,) tile origins
    centre = (tile - 1) / 2
    with torch.no_grad():
        centres = Pixels(
            (tx + centre).expand(batch, -1), (ty + centre).expand(batch, -1), width, height
        )
        near = brush.bound(x.detach(), centres) <= tile / math.sqrt(2) + margin
    b, t = near.nonzero(as_tuple=True)

    py = (ty[t, None, None] + offs[None, :, None]).expand(-1, tile, tile)
    px = (tx[t, None, None] + offs[None, None, :]).expand(-1, tile, tile)
    pixels = Pixels(px.reshape(len(t), tile * tile), py.reshape(len(t), tile * tile), width, height)
    fg, alpha = brush.paint(x[b], pixels, coverage)  # (P, 3, N), (P, N)

    values = torch.cat([fg, alpha[:, None]], 1)  # (P, 4, N)
    tiles = x.new_zeros(batch, nty * ntx, 4, tile * tile).index_put((b, t), values)
    image = (
        tiles.view(batch, nty, ntx, 4, tile, tile)
        .permute(0, 3, 1, 4, 2, 5)
        .reshape(batch, 4, nty * tile, ntx * tile)[:, :, :height, :width]
    )
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
