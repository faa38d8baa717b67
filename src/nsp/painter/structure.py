"""The target's local structure, which a new stroke follows (paper §3.6, progressive rendering: each
new stroke starts where and as the picture asks): the direction of the forms at a pixel, from the
structure tensor, and how far the colour there reaches along and across them (the scale of detail).
"""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.engine.device import to_device

FLAT = 1e-6  # structure-tensor trace below which a neighbourhood has no direction to follow


def smooth(image: Tensor, k: int) -> Tensor:
    """Mean over a k×k window (k odd), the border averaging only pixels inside: (B, C, h, w) -> same."""
    return F.avg_pool2d(image, k, stride=1, padding=k // 2, count_include_pad=False)


def structure_tensor(image: Tensor, window: int) -> Tensor:
    """(B, 3, h, w): J = (Jxx, Jyy, Jxy), the luminance gradient's outer product averaged twice over
    a ``window``-wide box (about a Gaussian), of image (B, 3, h, w); gradients by Sobel after a
    3×3 pre-smoothing, so single-pixel noise does not set the direction."""
    gray = smooth(image.mean(1, keepdim=True), 3)
    padded = F.pad(gray, (1, 1, 1, 1), mode="replicate")
    sobel = torch.tensor([[-1.0, 0.0, 1.0], [-2.0, 0.0, 2.0], [-1.0, 0.0, 1.0]], dtype=image.dtype, device="cpu") / 8
    sobel = to_device(sobel, image.device)
    gx = F.conv2d(padded, sobel[None, None])
    gy = F.conv2d(padded, sobel.T[None, None])
    return smooth(smooth(torch.cat([gx * gx, gy * gy, gx * gy], 1), window), window)


def orientation(j: Tensor) -> tuple[Tensor, Tensor]:
    """Direction along the forms and how clear it is, from structure tensors j (..., 3): the angle (...)
    in radians (x right, y down) of the eigenvector of J's smaller eigenvalue (along edges and stripes),
    and the coherence ((λ1 − λ2) / (λ1 + λ2))² in [0, 1] (0: no direction, or flat; 1: one clean edge)."""
    jxx, jyy, jxy = j.unbind(-1)
    trace = jxx + jyy
    spread = torch.sqrt((jxx - jyy) ** 2 + 4 * jxy**2)
    coherence = torch.where(trace > FLAT, (spread / trace.clamp_min(FLAT)) ** 2, torch.zeros_like(trace))
    return 0.5 * torch.atan2(2 * jxy, jxx - jyy) + math.pi / 2, coherence.clamp(0, 1)


def reach(target: Tensor, canvas: Tensor, row: Tensor, col: Tensor, angle: Tensor, color: Tensor, limit: float,
          samples: int = 12) -> tuple[Tensor, Tensor]:
    """How far painting ``color`` from (row, col) on improves the canvas, in four directions: the
    scale of the detail there, as far as this canvas still misses it.

    target, canvas: (B, 3, h, w); row, col: (B, P) pixels, P of each block; angle: (B, P) radians;
    color: (B, P, 3). Walks out along ±angle and the two perpendiculars in ``samples`` equal steps up
    to ``limit`` px, stopping before the first sample where ``color`` is no closer to the target than
    the canvas is (mean absolute channel difference), or past the block.

    Returns (B, P, 4, samples + 1, 3) the target's colours passed on each walk (the point itself
    first; samples past the stop repeat the last one inside) and (B, P, 4) the distances reached in
    pixels, in the order along+, along−, across+, across−.
    """
    _, _, h, w = target.shape
    steps = torch.linspace(0, limit, samples + 1, dtype=target.dtype, device=target.device)  # (S+1,)
    turns = torch.stack([angle + turn for turn in (0.0, math.pi, math.pi / 2, -math.pi / 2)], -1)  # (B, P, 4)
    px = col[..., None, None] + torch.cos(turns)[..., None] * steps  # (B, P, 4, S+1)
    py = row[..., None, None] + torch.sin(turns)[..., None] * steps
    grid = torch.stack([2 * px / max(w - 1, 1) - 1, 2 * py / max(h - 1, 1) - 1], -1)  # (B, P, 4, S+1, 2)
    both = F.grid_sample(torch.cat([target, canvas], 1), grid.flatten(1, 2), mode="bilinear", padding_mode="border",
                         align_corners=True).permute(0, 2, 3, 1).unflatten(1, px.shape[1:3])  # (B, P, 4, S+1, 6)
    seen, painted = both[..., :3], both[..., 3:]
    outside = (px < 0) | (px > w - 1) | (py < 0) | (py > h - 1)
    worse = (seen - color[:, :, None, None]).abs().mean(-1) >= (seen - painted).abs().mean(-1)
    inside = torch.cumprod((~(worse | outside)).to(target.dtype), -1).bool()  # True up to the first stop
    inside[..., 0] = True
    last = inside.sum(-1, keepdim=True) - 1  # (B, P, 4, 1) index of the last sample inside
    kept = torch.where(inside[..., None], seen, seen.gather(-2, last[..., None].expand(*last.shape, 3)))
    return kept, steps[last[..., 0]]
