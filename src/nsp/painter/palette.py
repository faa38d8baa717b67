"""The colours a stroke may take: those of the target around it (no paint the photo does not justify,
e.g. a white stroke across a face whose brightest skin is beige)."""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.engine.device import to_device


class Palette:
    """The colours of target blocks around each pixel, within a window of the 3×3-smoothed target (a
    lone pixel counts little), which a stroke's colours are kept near. Not a per-channel range: between
    a beige face and a dark ground that would allow a green no pixel there has.

    Args:
        brush: the strokes' brush (where its points and colours are among its parameters).
        colors: (B, 3, h, w) the blocks as they should look, 3×3-smoothed (:attr:`Forms.colors
            <nsp.painter.placement.Forms>`, :func:`~nsp.painter.structure.smooth`).
        window: side of the window in block pixels (made odd).
        margin: how far (RGB distance) from the nearest of them a colour may go.
    """

    def __init__(self, brush: Brush, colors: Tensor, window: int, margin: float = 0.1):
        blocks, _, self.h, self.w = colors.shape
        self.table = colors.permute(0, 2, 3, 1).reshape(blocks * self.h * self.w, 3)  # a block's pixel a row
        half = (window | 1) // 2
        offsets = torch.arange(-half, half + 1, device=colors.device)
        self.dy, self.dx = offsets.repeat_interleave(len(offsets)), offsets.repeat(len(offsets))  # (n,) each
        self.scale = to_device(torch.tensor([self.w - 1, self.h - 1], dtype=colors.dtype, device="cpu"),
                               colors.device)  # a centre (x, y) in block pixels
        self.points = _params(brush, ("x", "y"), colors.device)  # a stroke's xs, then its ys
        self.paints = _params(brush, ("color",), colors.device)
        self.margin = margin

    def clamp_(self, x: Tensor, blocks: Tensor) -> None:
        """Move, in place, each colour of strokes x (b, K, d) of the blocks ``blocks`` (b,), on x's device,
        to within ``margin`` of the nearest colour in the window at the stroke's centre (the mean of its points)."""
        b, k, _ = x.shape
        points = x.index_select(-1, self.points).unflatten(-1, (2, -1))  # (b, K, 2, p): xs, ys
        col, row = (points.mean(-1) * self.scale).round().long().unbind(-1)
        rows = (row[..., None] + self.dy).clamp_(0, self.h - 1)  # (b, K, n)
        cols = (col[..., None] + self.dx).clamp_(0, self.w - 1)
        pixel = (blocks[:, None, None] * self.h + rows) * self.w + cols
        near = self.table.index_select(0, pixel.flatten()).view(b, k, -1, 3)  # (b, K, n, 3)
        c = x.index_select(-1, self.paints).unflatten(-1, (-1, 3))  # (b, K, r, 3): a brush's r colours
        distance = (c[..., None, :] - near[..., None, :, :]).square().sum(-1)  # (b, K, r, n), squared
        nearest = torch.gather(near, 2, distance.argmin(-1, keepdim=True).expand(*c.shape))  # (b, K, r, 3)
        away = c - nearest
        reach = away.norm(dim=-1, keepdim=True)
        x[..., self.paints] = (nearest + away * (self.margin / reach.clamp(min=self.margin))).flatten(-2)


def _params(brush: Brush, kinds: tuple[str, ...], device: torch.device) -> Tensor:
    """The indices of ``brush``'s parameters of each of ``kinds``, kind after kind."""
    return to_device(torch.tensor([i for kind in kinds for i, k in enumerate(brush.kinds) if k == kind], device="cpu"),
                     device)
