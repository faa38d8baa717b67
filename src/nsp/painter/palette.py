"""The colours a stroke may take: those of the target around it (no paint the photo does not justify,
e.g. a white stroke across a face whose brightest skin is beige)."""
from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes import Brush
from nsp.painter.structure import smooth


class Palette:
    """Per-pixel colour ranges of target blocks: the darkest and brightest of each channel within a
    window around the pixel (of the 3×3-smoothed target, so a lone pixel does not widen it).

    Args:
        target: (B, 3, h, w) the blocks as they should look.
        window: side of the window in block pixels (made odd).
        margin: how far past the range a colour may go.
    """

    def __init__(self, target: Tensor, window: int, margin: float = 0.02):
        k = window | 1
        smoothed = smooth(target, 3)
        self.low = -window_max(-smoothed, k) - margin  # (B, 3, h, w)
        self.high = window_max(smoothed, k) + margin

    def clamp_(self, brush: Brush, x: Tensor, blocks: Tensor) -> None:
        """Clamp, in place, the colours of strokes x (b, K, d) of the blocks ``blocks`` (b,) to the
        range at each stroke's centre (the mean of its points)."""
        _, _, h, w = self.low.shape
        xs = [i for i, k in enumerate(brush.kinds) if k == "x"]
        ys = [i for i, k in enumerate(brush.kinds) if k == "y"]
        col = (x[..., xs].mean(-1) * (w - 1)).round().long().clamp(0, w - 1)  # (b, K)
        row = (x[..., ys].mean(-1) * (h - 1)).round().long().clamp(0, h - 1)
        block = blocks[:, None].expand_as(row)
        low = self.low[block, :, row, col]  # (b, K, 3)
        high = self.high[block, :, row, col]
        colors = [i for i, k in enumerate(brush.kinds) if k == "color"]
        repeat = len(colors) // 3
        x[..., colors] = torch.maximum(torch.minimum(x[..., colors], high.repeat(1, 1, repeat)), low.repeat(1, 1, repeat))


def window_max(image: Tensor, k: int) -> Tensor:
    """The largest value of each k×k window (k odd) centred on each pixel of ``image`` (B, C, h, w),
    the same size: along the columns, then the rows (k times fewer comparisons than the square)."""
    tall = F.max_pool2d(image, (k, 1), stride=1, padding=(k // 2, 0))
    return F.max_pool2d(tall, (1, k), stride=1, padding=(0, k // 2))
