"""The colours a stroke may take: those of the target around it (no paint the photo does not justify,
e.g. a white stroke across a face whose brightest skin is beige)."""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.brushes import Brush


class Palette:
    """The colours of target blocks around each pixel: those of the pixels within a window (of the
    3×3-smoothed target, so a lone pixel counts little and edges' blends count), which a stroke's
    colours are kept near. Not a per-channel range: between a beige face and a dark ground that
    would allow a green no pixel there has.

    Args:
        colors: (B, 3, h, w) the blocks as they should look, 3×3-smoothed (:attr:`Forms.colors
            <nsp.painter.placement.Forms>`, :func:`~nsp.painter.structure.smooth`).
        window: side of the window in block pixels (made odd).
        margin: how far (RGB distance) from the nearest of them a colour may go.
    """

    def __init__(self, colors: Tensor, window: int, margin: float = 0.1):
        self.colors = colors
        half = (window | 1) // 2
        offsets = torch.arange(-half, half + 1, device=colors.device)
        self.dy, self.dx = offsets.repeat_interleave(len(offsets)), offsets.repeat(len(offsets))  # (n,) each
        self.margin = margin

    def clamp_(self, brush: Brush, x: Tensor, blocks: Tensor) -> None:
        """Move, in place, each colour of strokes x (b, K, d) of the blocks ``blocks`` (b,) to within
        ``margin`` of the nearest colour in the window at the stroke's centre (the mean of its points)."""
        _, _, h, w = self.colors.shape
        xs = [i for i, k in enumerate(brush.kinds) if k == "x"]
        ys = [i for i, k in enumerate(brush.kinds) if k == "y"]
        col = (x[..., xs].mean(-1) * (w - 1)).round().long()  # (b, K)
        row = (x[..., ys].mean(-1) * (h - 1)).round().long()
        rows = (row[..., None] + self.dy).clamp(0, h - 1)  # (b, K, n)
        cols = (col[..., None] + self.dx).clamp(0, w - 1)
        block = blocks[:, None, None].expand_as(rows)
        near = self.colors[block, :, rows, cols]  # (b, K, n, 3)
        colors = [i for i, k in enumerate(brush.kinds) if k == "color"]
        c = x[..., colors].unflatten(-1, (-1, 3))  # (b, K, r, 3): a brush's r colours
        distance = torch.cdist(c, near)  # (b, K, r, n)
        nearest = torch.gather(near, 2, distance.argmin(-1, keepdim=True).expand(*c.shape))  # (b, K, r, 3)
        away = c - nearest
        reach = away.norm(dim=-1, keepdim=True)
        x[..., colors] = (nearest + away * (self.margin / reach.clamp(min=self.margin))).flatten(-2)
