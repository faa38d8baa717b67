"""Signed distances in pixel units, shared by the brushes. Inputs broadcast; negative inside."""
from __future__ import annotations

import math

import torch
from torch import Tensor

_EPS = 1e-8


def to_pixels(x: Tensor, y: Tensor, width: int, height: int) -> tuple[Tensor, Tensor]:
    """Map positions in [0, 1] to pixel coordinates: p -> p·(W−1), p·(H−1)."""
    return x * (width - 1), y * (height - 1)


def rotated_frame(px: Tensor, py: Tensor, cx: Tensor, cy: Tensor, theta: Tensor) -> tuple[Tensor, Tensor]:
    """Coordinates of pixels in a frame centred at (cx, cy) whose first axis points at angle θ·π.

    The angle is measured from +x towards +y (y points down). Returns (along, across), each (P, N).
    """
    angle = theta * math.pi
    cos, sin = torch.cos(angle)[:, None], torch.sin(angle)[:, None]
    dx, dy = px - cx[:, None], py - cy[:, None]
    return dx * cos + dy * sin, -dx * sin + dy * cos


def box(along: Tensor, across: Tensor, half_w: Tensor, half_h: Tensor) -> Tensor:
    """Exact signed distance to an axis-aligned box of half extents (half_w, half_h): (P, N)."""
    qx = along.abs() - half_w[:, None]
    qy = across.abs() - half_h[:, None]
    outside = torch.sqrt(qx.clamp(min=0) ** 2 + qy.clamp(min=0) ** 2 + _EPS) - math.sqrt(_EPS)
    return outside + torch.maximum(qx, qy).clamp(max=0)


def bezier_polyline(p0: Tensor, p1: Tensor, p2: Tensor, segments: int) -> Tensor:
    """Points of the quadratic Bézier B(t)=(1−t)²P0+2(1−t)tP1+t²P2 at t = k/segments.

    p0, p1, p2: (P, 2). Returns (P, segments + 1, 2).
    """
    t = torch.linspace(0, 1, segments + 1, device=p0.device, dtype=p0.dtype)[None, :, None]
    return (1 - t) ** 2 * p0[:, None] + 2 * (1 - t) * t * p1[:, None] + t**2 * p2[:, None]


def segments_for(width: int, height: int) -> int:
    """Polyline segments for a Bézier at this resolution: chord error stays below about a pixel."""
    return int(min(32, max(8, math.ceil(math.sqrt(max(width, height)) / 1.4))))


def project_polyline(points: Tensor, px: Tensor, py: Tensor) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """Project pixels onto each segment of a polyline.

    points: (P, K+1, 2); px, py: (P, N).
    Returns (along, perp, length, s), each (P, N, K): the signed position along segment k from its
    start (pixels), the distance from its line, its length, and the clamped fraction s ∈ [0, 1].
    """
    a, b = points[:, None, :-1], points[:, None, 1:]  # (P, 1, K, 2)
    ab = b - a
    length = torch.sqrt((ab**2).sum(-1) + _EPS)  # (P, 1, K)
    ux, uy = ab[..., 0] / length, ab[..., 1] / length
    apx, apy = px[..., None] - a[..., 0], py[..., None] - a[..., 1]  # (P, N, K)
    along = apx * ux + apy * uy
    perp = (apx * uy - apy * ux).abs()
    s = (along / length).clamp(0, 1)
    return along, perp, length.expand_as(along), s
