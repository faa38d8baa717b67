"""Colour mode (paper §3.5): one recolouring shared by the whole painting.

The painting's colour distribution is carried onto the style image's by optimal transport in
L*a*b* (:mod:`nsp.style.color`) between the two distributions' Gaussian approximations. There the
optimal map is affine, so colours that were alike stay alike. Lightness and chroma go apart:

- chroma (a*, b*), all the way: c ↦ μ_s + A(c − μ_p), A = Σ_p^-½ (Σ_p^½ Σ_s Σ_p^½)^½ Σ_p^-½, the
  transport map between the painting's (p) and the style's (s) Gaussians. The photo's hues are not
  its content: they are what colour mode replaces. A's stretch is capped (:data:`STRETCH`): a
  drab painting carried onto a vivid style would otherwise pull its near-alike colours apart.
- lightness L, a ``step`` t ∈ [0, 1] of the way: L carries the photo's content, so it moves along
  the transport path L' = L + t·(T(L) − L), T the transport map between the two lightness
  Gaussians. T is affine and increasing, so L' is too: tones keep their order, edges stay edges,
  and t = 1 gives the style's mean and spread of lightness (the spread's stretch capped as
  chroma's). How far to go depends on how much
  luminance structure a step costs, which only the painting shows: ``nsp.painter.stylize`` chooses t.
"""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.style.color import lab_to_rgb, rgb_to_lab

EPS = 1e-4  # added to the painting's covariance: (1 ΔE)², so a grey painting's chroma stays invertible
STRETCH = 2.0  # the most the map may stretch colour differences: A's largest eigenvalue, T's slope


class Recoloring:
    """The affine map lab ↦ mean_out + matrix·(lab − mean_in) of L*a*b* / 100 colours, applied to RGB.

    Args:
        mean_in, mean_out: (3,) L*a*b* / 100 means of the painting and of its recolouring.
        matrix: (3, 3), block-diagonal: lightness alone, then chroma.
        step: how far the lightness moved toward the style's, in [0, 1].
    """

    def __init__(self, mean_in: Tensor, mean_out: Tensor, matrix: Tensor, step: float = 0.0):
        self.mean_in, self.mean_out, self.matrix, self.step = mean_in, mean_out, matrix, step

    @classmethod
    def fit(cls, painting: Tensor, style: Tensor, step: float = 0.0) -> Recoloring:
        """The recolouring of ``painting`` (3, H, W) toward ``style`` (3, h, w), both RGB in [0, 1];
        ``step`` ∈ [0, 1]: how far the lightness moves toward the style's (0: kept, 1: the style's
        mean and spread)."""
        if not 0 <= step <= 1:
            raise ValueError(f"lightness step {step}: expected 0 ≤ step ≤ 1")
        p = rgb_to_lab(painting.detach().flatten(1).cpu().double(), dim=0)  # (3, N); a 3×3 fit: on the CPU
        s = rgb_to_lab(style.detach().flatten(1).cpu().double(), dim=0)  # (3, M)
        mean_p, mean_s = p.mean(1), s.mean(1)
        t = float(step)
        scale = (s[0].std() / (p[0].var() + EPS).sqrt()).clamp(max=STRETCH)
        matrix = torch.zeros(3, 3, dtype=torch.float64)
        matrix[0, 0] = 1 - t + t * scale
        chroma = gaussian_transport(torch.cov(p[1:]) + EPS * torch.eye(2, dtype=p.dtype), torch.cov(s[1:]))
        values, vectors = torch.linalg.eigh(chroma)
        matrix[1:, 1:] = vectors @ torch.diag(values.clamp(max=STRETCH)) @ vectors.T
        mean_out = torch.cat([mean_p[:1] + t * (mean_s[:1] - mean_p[:1]), mean_s[1:]])
        return cls(mean_p.float(), mean_out.float(), matrix.float(), t)

    def __call__(self, rgb: Tensor, dim: int = -1) -> Tensor:
        """Recoloured ``rgb`` in [0, 1], channels along ``dim`` (any shape); out of gamut: clamped."""
        lab = rgb_to_lab(rgb, dim).movedim(dim, -1)
        lab = self.mean_out.to(lab) + (lab - self.mean_in.to(lab)) @ self.matrix.to(lab).T
        return lab_to_rgb(lab).clamp(0, 1).movedim(-1, dim)

    def strokes(self, brush: Brush, x: Tensor) -> Tensor:
        """Strokes (N, d) with every colour (each RGB triple of ``brush.color``) recoloured; all
        other parameters bit for bit."""
        color = list(brush.color)
        out = x.detach().clone()
        out[:, color] = self(x.detach()[:, color].reshape(len(x), -1, 3)).reshape(len(x), -1)
        return out


def gaussian_transport(source: Tensor, target: Tensor) -> Tensor:
    """The optimal transport map's matrix between centred Gaussians of covariances ``source`` and
    ``target`` (k, k): Σ₀^-½ (Σ₀^½ Σ₁ Σ₀^½)^½ Σ₀^-½, symmetric positive semi-definite."""
    root = _sqrtm(source)
    inverse = torch.linalg.inv(root)
    return inverse @ _sqrtm(root @ target @ root) @ inverse


def _sqrtm(matrix: Tensor) -> Tensor:
    """The square root of a symmetric positive semi-definite matrix (k, k)."""
    values, vectors = torch.linalg.eigh((matrix + matrix.T) / 2)
    return vectors @ torch.diag(values.clamp(min=0).sqrt()) @ vectors.T
