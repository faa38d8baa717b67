"""Geometry of the progressive schedule (paper §3, "progressive rendering"): levels of overlapping
square blocks, how many strokes each block gets, and how a block's strokes move onto the canvas.
A level may also cover regions only (the faces found in a photo) with finer blocks.

At level m the canvas is cut into m blocks along its long side (and proportionally fewer along a short one, so
blocks stay square for renderers with square outputs). A block whose square reaches past the canvas (level 1 of a
non-square image) is padded; its ``weights`` say which of its pixels are canvas.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.engine.device import to_device


def grid_shape(m: int, height: int, width: int) -> tuple[int, int]:
    """(rows, cols) of level m: m along the long side, about square cells along the short one."""
    if width >= height:
        return max(1, round(m * height / width)), m
    return m, max(1, round(m * width / height))


def progressive_grids(strokes: int, height: int, width: int, max_per_block: int, growth: float = 1.0) -> list[int]:
    """Levels m = 1, …, each the last's m·``growth`` rounded up (at least m + 1; growth 1 gives the
    paper's 1, 2, 3, …), as few as leave no block more than ``max_per_block`` strokes."""
    grids, blocks = [1], 1
    while math.ceil(strokes / blocks) > max_per_block:
        grids.append(max(grids[-1] + 1, math.ceil(grids[-1] * growth - 1e-9)))
        rows, cols = grid_shape(grids[-1], height, width)
        blocks += rows * cols
    return grids


def distribute(strokes: int, blocks: list[int]) -> list[Tensor]:
    """Split ``strokes`` over the blocks of each level, exactly: (blocks_l,) counts per level. Every
    block gets ⌊strokes / Σblocks⌋; the remainder goes one each to blocks of the finest levels first
    (detail is where extra strokes show), spread evenly across each level."""
    base, extra = divmod(strokes, sum(blocks))
    counts = [torch.full((n,), base, dtype=torch.long, device="cpu") for n in blocks]  # bookkeeping: the CPU
    for level in reversed(range(len(blocks))):
        n = blocks[level]
        take = min(extra, n)
        if take:
            counts[level][torch.arange(take, device="cpu") * n // take] += 1
        extra -= take
    return counts


def share(strokes: int, scores: Tensor, cap: int) -> Tensor:
    """Split ``strokes`` over blocks in proportion to their ``scores`` (B,) ≥ 0, none above ``cap``:
    (B,) long counts summing to exactly min(strokes, B·cap). Highest averages (D'Hondt): each stroke
    in turn goes to the block of the largest score / (strokes it has + 1) among those below the cap;
    ties go to the earlier block."""
    scores = scores.detach().double().cpu().clamp_min(0) + 1e-12  # bookkeeping on the CPU; blocks with nothing to fix still take what is left
    prices = scores[:, None] / torch.arange(1, cap + 1, dtype=torch.float64, device=scores.device)  # (B, cap), falling along a row
    order = torch.argsort(prices.flatten(), descending=True, stable=True)[:strokes]
    return torch.bincount(order // cap, minlength=len(scores))


@dataclass(frozen=True)
class Level:
    """One level: square blocks of ``side`` canvas pixels over a ``height``×``width`` canvas.

    Attributes:
        origins: (B, 2) long, each block's top-left pixel (y, x); negative or past the canvas
            where the block is padded.
        counts: (B,) long, strokes each block gets.
    """

    side: int
    origins: Tensor
    counts: Tensor
    height: int
    width: int

    @classmethod
    def grid(cls, m: int, height: int, width: int, overlap: float, counts: Tensor) -> "Level":
        """Level m with blocks ``overlap`` (a fraction of a cell) larger than their grid cell."""
        rows, cols = grid_shape(m, height, width)
        side = min(math.ceil(max(height / rows, width / cols) * (1 + overlap)), max(height, width))

        def starts(n: int, extent: int) -> Tensor:
            if n == 1:
                return torch.tensor([(extent - side) // 2], device="cpu")  # centred; padded if the block is larger
            return torch.linspace(0, extent - side, n, device="cpu").round().long()

        ys, xs = torch.meshgrid(starts(rows, height), starts(cols, width), indexing="ij")
        return cls(side, torch.stack([ys.flatten(), xs.flatten()], 1), counts, height, width)

    @classmethod
    def regions(cls, boxes: Sequence[tuple[float, float, float, float]], grid: int, height: int, width: int,
                strokes: int) -> "Level":
        """Blocks over parts of the canvas only: each box (top, left, height, width as fractions of
        the canvas) is tiled with square blocks, ``grid`` of them along the largest box's long side,
        the same side for all; ``strokes`` are shared equally among the blocks."""
        side = max(1, math.ceil(max(max(h * height, w * width) for _, _, h, w in boxes) / grid))
        origins = [(round(top * height) + i * side, round(left * width) + j * side)
                   for top, left, h, w in boxes
                   for i in range(max(1, math.ceil(h * height / side - 1e-9)))
                   for j in range(max(1, math.ceil(w * width / side - 1e-9)))]
        return cls(side, torch.tensor(origins, device="cpu"), distribute(strokes, [len(origins)])[0], height, width)

    @property
    def blocks(self) -> int:
        return len(self.origins)

    def crop(self, image: Tensor, size: int, pad: str = "replicate") -> Tensor:
        """The blocks of ``image`` (C, H, W), resampled to ``size``: (B, C, size, size). Pixels past
        the canvas repeat its edge (``pad="replicate"``) or are 0 (``"constant"``)."""
        s = self.side
        (low_y, low_x), (high_y, high_x) = self.origins.min(0).values.tolist(), self.origins.max(0).values.tolist()
        top, left, bottom, right = max(0, -low_y), max(0, -low_x), max(0, high_y + s - self.height), max(0, high_x + s - self.width)
        if top or left or bottom or right:
            image = F.pad(image[None], (left, right, top, bottom), mode=pad)[0]
        blocks = torch.stack([image[:, y + top : y + top + s, x + left : x + left + s] for y, x in self.origins.tolist()])
        if size == s:
            return blocks
        # area averaging when shrinking keeps thin detail; bilinear when a fixed-size renderer is larger
        mode = "area" if size < s else "bilinear"
        return F.interpolate(blocks, size=(size, size), mode=mode, **({} if mode == "area" else {"align_corners": False}))

    def weights(self, size: int, like: Tensor) -> Tensor:
        """(B, 1, size, size) in [0, 1]: the share of each block pixel that lies on the canvas."""
        return self.crop(like.new_ones(1, self.height, self.width), size, pad="constant")

    def to_canvas(self, x: Tensor, kinds: tuple[str, ...], size: int) -> Tensor:
        """Strokes x (B, K, d) in [0, 1] of each block, drawn on a ``size``-pixel block, in
        whole-canvas parameters (B, K, d): positions go through the block's pixels to the canvas's,
        sizes (fractions of the width) scale by side / W; the other ``kinds`` do not change."""
        scale = self.side / size  # canvas pixels per block pixel
        origins = to_device(self.origins, x.device).to(x.dtype)  # (B, 2): y, x

        def moved(value: Tensor, kind: str) -> Tensor:  # a parameter (B, K) of every stroke
            if kind in ("x", "y"):
                axis, extent = (1, self.width) if kind == "x" else (0, self.height)
                # block pixel p·(size−1) has its centre at canvas pixel origin + (p·(size−1) + ½)·scale − ½
                return ((value * (size - 1) + 0.5) * scale - 0.5 + origins[:, axis, None]) / max(extent - 1, 1)
            return value * self.side / self.width if kind == "size" else value

        return torch.stack([moved(value, kind) for value, kind in zip(x.unbind(-1), kinds)], -1).clamp(0, 1)
