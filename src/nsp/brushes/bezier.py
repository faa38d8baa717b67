"""Shared geometry of the Bézier brushes (watercolor, markerpen)."""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.brushes.base import Pixels
from nsp.engine.geometry import bezier_polyline, project_polyline, segments_for, to_pixels


def trajectory(x: Tensor, pix: Pixels) -> Tensor:
    """Polyline of the trajectory given by x[:, 0:6] = x0, y0, x1, y1, x2, y2: (P, K+1, 2) pixels."""
    pts = torch.stack(to_pixels(x[:, 0:6:2], x[:, 1:6:2], pix.width, pix.height), -1)  # (P, 3, 2)
    return bezier_polyline(pts[:, 0], pts[:, 1], pts[:, 2], segments_for(pix.width, pix.height))


def distance(points: Tensor, pix: Pixels) -> Tensor:
    """Distance from each pixel to the polyline: (P, N); 1-Lipschitz."""
    along, perp, length, _ = project_polyline(points, pix.px, pix.py)
    excess = torch.maximum(-along, along - length).clamp(min=0)
    return torch.sqrt(perp**2 + excess**2 + 1e-8).amin(-1)
