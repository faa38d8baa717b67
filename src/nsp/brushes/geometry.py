"""Signed distances in pixel units, shared by the brushes. Inputs broadcast; negative inside."""
from __future__ import annotations

import math

import torch
from torch import Tensor

_EPS = 1e-8


def antialiased(sd: Tensor) -> Tensor:
    """Box-filtered coverage of a pixel whose centre is ``sd`` pixels outside the edge."""
    return (0.5 - sd).clamp(0, 1)


def soft(sd: Tensor, softness: float = 1.0) -> Tensor:
    """Sigmoid coverage: differentiable everywhere, a ``softness``-pixel-wide edge."""
    return torch.sigmoid(-sd / softness)


def to_pixels(x: Tensor, y: Tensor, height: int, width: int) -> tuple[Tensor, Tensor]:
    """Map positions in [0, 1] to pixel coordinates: p -> p·(W−1), p·(H−1); sizes (height, width), as everywhere in nsp."""
    return x * (width - 1), y * (height - 1)


def rotated_frame(px: Tensor, py: Tensor, cx: Tensor, cy: Tensor, theta: Tensor) -> tuple[Tensor, Tensor]:
    """Coordinates (along, across), each (P, N), of pixels in a frame centred at (cx, cy) whose first
    axis points at angle θ·π, measured from +x towards +y (y points down)."""
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


def _cbrt(v: Tensor) -> Tensor:
    return v.sign() * v.abs().pow(1 / 3)


def _distance_minima(p0: Tensor, a: Tensor, b: Tensor, px: Tensor, py: Tensor) -> tuple[Tensor, Tensor, Tensor]:
    """The (up to two) local minima t ∈ [0, 1] of |B(t) − p| for B(t) = P0 + 2t·a + t²·b, the later
    first, and the maximum between them (the minimum where there is one): (P, N) each, for p0, a, b
    (P, 2) and px, py (P, N). d|B(t) − p|²/dt = 0 is the cubic (b·b)t³ + 3(a·b)t² + (2a·a + m·b)t + m·a = 0,
    m = P0 − p, solved in closed form (Cardano for one real root, returned twice; the trigonometric form
    for three, the middle one a distance maximum); nearly straight strokes use the chord instead."""
    bb, ab, aa = (b * b).sum(1, keepdim=True), (a * b).sum(1, keepdim=True), (a * a).sum(1, keepdim=True)
    straight = bb <= 1e-6 * aa + 1e-12
    k = 1 / torch.where(straight, torch.ones_like(bb), bb)
    mx, my = p0[:, :1] - px, p0[:, 1:] - py
    kx = k * ab
    ky = k * (2 * aa + mx * b[:, :1] + my * b[:, 1:]) / 3
    kz = k * (mx * a[:, :1] + my * a[:, 1:])
    # Depressed cubic s³ + 3·P·s + Q = 0 with t = s − kx.
    p_ = ky - kx * kx
    q_ = kx * (2 * kx * kx - 3 * ky) + kz
    h = q_ * q_ + 4 * p_ * p_ * p_
    root = torch.sqrt(h.clamp(min=0))
    one = _cbrt((root - q_) / 2) + _cbrt((-root - q_) / 2) - kx
    z = torch.sqrt((-p_).clamp(min=1e-30))
    phi = torch.acos((-q_ / (2 * (-p_).clamp(min=1e-30) * z)).clamp(-1, 1)) / 3
    largest = 2 * z * torch.cos(phi) - kx
    smallest = 2 * z * torch.cos(phi - 4 * math.pi / 3) - kx
    chord = 2 * a + b  # P2 − P0
    along = (-(mx * chord[:, :1] + my * chord[:, 1:]) / (chord * chord).sum(1, keepdim=True).clamp(min=1e-12))
    middle = 2 * z * torch.cos(phi - 2 * math.pi / 3) - kx
    t1 = torch.where(straight, along, torch.where(h >= 0, one, largest)).clamp(0, 1)
    t2 = torch.where(straight, along, torch.where(h >= 0, one, smallest)).clamp(0, 1)
    return t1, t2, torch.where(straight | (h >= 0), t1, middle.clamp(0, 1))


def _reach(t: Tensor, p0: Tensor, a: Tensor, b: Tensor, px: Tensor, py: Tensor, taper) -> Tensor:
    """φ(t) = |B(t) − p| − taper·t; t broadcasts against px, py and the (P, 1) coefficient columns."""
    qx = p0[:, :1] + t * (2 * a[:, :1] + t * b[:, :1]) - px
    qy = p0[:, 1:] + t * (2 * a[:, 1:] + t * b[:, 1:]) - py
    return torch.sqrt(qx * qx + qy * qy + _EPS) - (0 if taper is None else taper * t)


def _newton_step(t: Tensor, p0: Tensor, a: Tensor, b: Tensor, px: Tensor, py: Tensor, taper) -> Tensor:
    """One safeguarded Newton step on φ(t) = |B(t) − p| − taper·t from t (P, N), kept in [0, 1],
    carrying the implicit-function gradient dt/dθ = −(∂φ'/∂θ) / φ'' of the minimum it refines. The
    step is taken only where it lowers φ, so a pixel on the curve (where |B − p| has a kink) or an
    inflection of φ never moves to a worse disc; the gradient does not depend on whether it was (a step
    that gains no more than rounding starts at the minimum already). An end (0 or 1): no gradient."""
    taper = None if taper is None else taper[:, None]
    qx = p0[:, :1] + t * (2 * a[:, :1] + t * b[:, :1]) - px
    qy = p0[:, 1:] + t * (2 * a[:, 1:] + t * b[:, 1:]) - py
    dx, dy = 2 * (a[:, :1] + t * b[:, :1]), 2 * (a[:, 1:] + t * b[:, 1:])  # B'(t)
    norm = torch.sqrt(qx * qx + qy * qy + _EPS)
    along = (qx * dx + qy * dy) / norm
    slope = along - (0 if taper is None else taper)  # φ'(t)
    with torch.no_grad():
        curvature = (dx * dx + dy * dy + 2 * (qx * b[:, :1] + qy * b[:, 1:]) - along * along) / norm  # φ''(t)
        # Step from an end only when φ falls inwards (a growing disc reaching past the end).
        s = slope.detach()
        movable = ((t > 0) & (t < 1)) | ((t <= 0) & (s < 0)) | ((t >= 1) & (s > 0))
        convex = curvature > 1e-3
        stepped = (t - s / curvature.clamp(min=1e-3)).clamp(0, 1)
        better = _reach(stepped, p0, a, b, px, py, taper) < norm - (0 if taper is None else taper * t)  # φ(t)
        t = torch.where(movable & convex & better, stepped, t)
        moves = convex & (t > 0) & (t < 1)
    step = torch.where(moves, slope / curvature.clamp(min=1e-3), 0)
    return t - (step - step.detach())


def bezier_nearest(p0: Tensor, p1: Tensor, p2: Tensor, px: Tensor, py: Tensor, taper: Tensor | None = None,
                   samples: int = 12) -> Tensor:
    """t ∈ [0, 1] minimizing φ(t) = |B(t) − p| − taper·t for each pixel: (P, N).

    With ``taper`` = r2 − r0, the disc of a swept, linearly growing radius reaching furthest towards p:
    φ may then have several local minima (a hooked curve, a far wide disc), so both closed-form distance
    minima compete with ``samples`` evenly spaced t (12 leave no holes in tests/test_brushes.py); two
    safeguarded Newton steps refine the winner, the last with autograd (:func:`_newton_step`).
    p0, p1, p2: (P, 2) pixels; px, py: (P, N); taper: (P,) pixels or None."""
    return _nearest(p0, p1, p2, px, py, taper, samples)[0]


def swept_discs(p0: Tensor, p1: Tensor, p2: Tensor, px: Tensor, py: Tensor, taper: Tensor,
                samples: int = 12) -> tuple[Tensor, Tensor]:
    """Discs of a linearly growing radius (``taper`` = r2 − r0, (P,) pixels) swept along B, drawn in
    order of t: per pixel, the t of the disc reaching furthest towards it (:func:`bezier_nearest`),
    and the t of the later pass where the stroke passes the pixel twice, else the same t: (P, N) each.

    Where a stroke curls over a pixel (two distance minima), the later pass's discs are drawn on top.
    Every pixel computes both (no stroke is picked out: nothing waits for the device); both t carry
    gradients."""
    t, (t_last, t_first, between) = _nearest(p0, p1, p2, px, py, taper, samples)
    a, b = p1 - p0, p0 - 2 * p1 + p2
    later = _stationary(t_last, p0, a, b, px, py)
    # Two passes count as two once the distance rises by a pixel between them; as they merge, the
    # later one's weight goes smoothly to zero, so the colour has no seam there (one pass: all three
    # t are the same, and so is the weight, zero).
    distance = [_reach(u, p0, a, b, px, py, None) for u in (between, t_last, t_first)]  # stationary in t
    apart = (distance[0] - torch.maximum(distance[1], distance[2])).clamp(0, 1)
    return t, t + apart * (later - t)


def _stationary(t: Tensor, p0: Tensor, a: Tensor, b: Tensor, px: Tensor, py: Tensor) -> Tensor:
    """t (P, N), a local minimum of |B(t) − p| found without gradient, with the implicit-function
    gradient dt/dθ = −(∂g/∂θ) / g' of its condition g = (B(t) − p)·B'(t) = 0; an end (t = 0 or 1)
    stays put."""
    qx = p0[:, :1] + t * (2 * a[:, :1] + t * b[:, :1]) - px
    qy = p0[:, 1:] + t * (2 * a[:, 1:] + t * b[:, 1:]) - py
    dx, dy = 2 * (a[:, :1] + t * b[:, :1]), 2 * (a[:, 1:] + t * b[:, 1:])  # B'(t)
    g = qx * dx + qy * dy
    slope = (dx * dx + dy * dy + 2 * (qx * b[:, :1] + qy * b[:, 1:])).detach()  # g'(t) > 0 at a minimum
    inside = ((t > 0) & (t < 1)).to(t.dtype)
    step = inside * g / slope.clamp(min=1e-6)
    return t - (step - step.detach())


def _nearest(p0: Tensor, p1: Tensor, p2: Tensor, px: Tensor, py: Tensor, taper: Tensor | None,
             samples: int) -> tuple[Tensor, tuple[Tensor, Tensor, Tensor]]:
    """:func:`bezier_nearest`'s t (P, N), and :func:`_distance_minima`'s three (no gradient)."""
    a, b = p1 - p0, p0 - 2 * p1 + p2
    with torch.no_grad():  # the search: elementwise over pixels, so a compiled kernel fuses it
        t1, t2, between = _distance_minima(p0, a, b, px, py)
        column = None if taper is None else taper[:, None]
        reach1, reach2 = _reach(t1, p0, a, b, px, py, column), _reach(t2, p0, a, b, px, py, column)
        t, reach = torch.where(reach1 <= reach2, t1, t2), torch.minimum(reach1, reach2)
        for k in range(samples if taper is not None else 0):
            at = k / (samples - 1)
            sampled = _reach(at, p0, a, b, px, py, column)
            t, reach = torch.where(sampled < reach, at, t), torch.minimum(sampled, reach)
        t = _newton_step(t, p0, a, b, px, py, taper)
    return _newton_step(t, p0, a, b, px, py, taper), (t1, t2, between)
