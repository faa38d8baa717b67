"""Deterministic noise for paint that varies within a stroke (oil's bristles, watercolor's paper, the
marker's streaks): an integer hash of a stroke's key and a lattice cell, so a pattern is the same at
every render size and differs from stroke to stroke; and how much of a pattern a canvas can show."""
from __future__ import annotations

import torch
from torch import Tensor

NOISE_STD = 0.2145  # of value noise (measured, 2·10⁶ samples)
FAINTEST = 0.01  # a pattern drawn with less weight than this is left to its mean
_MASK = 0xFFFFFFFF
_CROSS, _LONG = 0x27D4EB2F, 0x165667B1  # a lattice step's change of the hashed integer, across and along


def mix(h: Tensor) -> Tensor:
    """An integer hash: (…) int64 in [0, 2³²) -> (…) int64 in [0, 2³²) (the product stays < 2⁶³)."""
    h = ((h ^ (h >> 16)) * 0x7FEB352D) & _MASK
    return h ^ (h >> 15)


def stroke_keys(seed: int, index: Tensor) -> Tensor:
    """Each stroke's key from the painting's ``seed`` and the strokes' ``index`` (B,) int64: (B,)."""
    return mix(((index & _MASK) * 0x2545F491 + ((seed * 0x85EBCA6B) & _MASK)) & _MASK)


def uniform(h: Tensor) -> Tensor:
    """A hash -> float in [0, 1)."""
    return (h & 0xFFFFFF).to(torch.float32) / float(1 << 24)


def ramp(lo: float, hi: float, x: Tensor) -> Tensor:
    """0 below ``lo``, 1 above ``hi``, linear between."""
    return ((x - lo) * (1 / (hi - lo))).clamp(0, 1)


def seen(pixels: Tensor) -> Tensor:
    """How much of a pattern whose cells span ``pixels`` px is drawn (1) or replaced by its mean (0)."""
    t = (pixels - 1.0).clamp(0, 1)
    return t * t * (3 - 2 * t)


def drawn(cells: tuple[float, ...], scale: float) -> tuple[bool, ...]:
    """Which patterns of cells ``cells`` canvas widths wide a canvas ``scale`` px wide draws (their
    weight by :func:`seen` at least :data:`FAINTEST`): as a tuple, it names a compiled kernel."""
    width = torch.tensor(scale, dtype=torch.float64, device="cpu")  # a number, not a pixel
    return tuple(bool(seen(cell * width) >= FAINTEST) for cell in cells)


def value_noise(cross: Tensor, long: Tensor, seed: Tensor | int) -> tuple[Tensor, Tensor]:
    """Value noise at lattice coordinates (cross, long) (P, N), knots drawn from ``seed`` (P, 1) or an
    int: its value in [0, 1] and its slope along ``cross``, each (P, N)."""
    i, j = torch.floor(cross), torch.floor(long)
    fi, fj = cross - i, long - j
    corner = seed + i.to(torch.int64) * _CROSS + j.to(torch.int64) * _LONG
    h00, h10 = uniform(mix(corner & _MASK)), uniform(mix((corner + _CROSS) & _MASK))
    h01, h11 = uniform(mix((corner + _LONG) & _MASK)), uniform(mix((corner + _CROSS + _LONG) & _MASK))
    wi, wj = fi * fi * (3 - 2 * fi), fj * fj * (3 - 2 * fj)
    near, far = h00 + (h10 - h00) * wi, h01 + (h11 - h01) * wi
    return near + (far - near) * wj, 6 * fi * (1 - fi) * ((h10 - h00) * (1 - wj) + (h11 - h01) * wj)
