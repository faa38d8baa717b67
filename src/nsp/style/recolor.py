"""Colour mode (paper §3.5): one recolouring shared by the whole painting.

A :class:`Recoloring` maps L*a*b* / 100 colours (:mod:`nsp.style.color`):

- lightness L ↦ f(L), f increasing and piecewise linear over :data:`KNOTS` pieces of [0, 1], its
  slope at most :data:`STRETCH`: tones keep their order, so edges stay edges;
- chroma c = (a*, b*) ↦ μ_s + A(c − μ_p) + g(L), A a 2×2 matrix and g piecewise linear in L: a tone
  may take a hue of its own (the style's shadows blue, its lights yellow).

It is one map for every stroke and the canvas colour, so colours that were alike stay alike.

- :meth:`Recoloring.fit` is the start: A is the optimal transport map between the Gaussian
  approximations of the painting's (p) and the style's (s) chroma, Σ_p^-½ (Σ_p^½ Σ_s Σ_p^½)^½ Σ_p^-½,
  its stretch capped at :data:`STRETCH` (a drab painting carried onto a vivid style would
  otherwise pull its near-alike colours apart); f is the identity and g zero. The photo's hues are
  not its content: they are what colour mode replaces. Its lightness is.
- :meth:`Recoloring.refine` then fits f, g and A to the style's colours themselves, by gradient
  steps on the painting's pixels: the sliced Wasserstein distance to the style's colours falls,
  while the luminance SSIM to the photo stays above a floor and colours alike in the painting stay
  within a bound of each other. A Gaussian map gives a grey photo the style's mean hue and little
  more; g spreads the style's hues over the tones, and f takes the style's tones as far as the
  floor allows.
- :meth:`Recoloring.matched_tones` is the other way to take the style's tones: f the tone
  quantiles matched (histogram matching), to go part of the way toward.
"""
from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import lab_to_rgb, rgb_to_lab
from nsp.images import ssim
from nsp.style.losses import sliced_wasserstein
from nsp.style.measures import alike_pairs, parted

EPS = 1e-4  # added to the painting's chroma covariance: (1 ΔE)², so a grey painting's stays invertible
STRETCH = 2.0  # the most the start stretches chroma differences (A's largest eigenvalue) and f's slope
KNOTS = 16  # f and g are linear on each of KNOTS equal pieces of L ∈ [0, 1]
STEPS = 150  # refine's gradient steps
RATE = 0.05  # refine's Adam learning rate, cosine-annealed to 0
HUE_RATE = RATE / 10  # g's: near black, a step of chroma leaves the sRGB gamut
PIXELS = 2048  # seeded pixels of the painting and of the style whose colours refine compares
PROJECTIONS = 32  # sliced Wasserstein directions a refine step draws
JUDGE = 128  # the fixed directions the iterates are compared on, every CHECK steps; the best is kept
CHECK = 10
PAIRS = 1024  # seeded pixels among which refine finds the alike pairs it holds together
PENALTY = 10.0  # the weight of a bound's excess against the colour distance
MARGIN = 0.1  # refine aims this share inside each bound: the strokes' blends differ a little from pixels'
HUED = 0.005  # a direction of chroma in which the style's colours vary less (standard deviation, 0.5 ΔE) takes no hue


class Recoloring:
    """The map of L*a*b* / 100 colours lab ↦ (f(L), mean_out + matrix·(c − mean_in) + g(L)), applied to RGB.

    Args:
        lightness: (KNOTS + 1,) f at L = 0, 1/KNOTS, …, 1, increasing.
        hue: (KNOTS + 1, 2) g at the same L.
        matrix: (2, 2) A.
        mean_in, mean_out: (2,) the chroma means of the painting and of its recolouring.
    """

    def __init__(self, lightness: Tensor, hue: Tensor, matrix: Tensor, mean_in: Tensor, mean_out: Tensor):
        self.lightness, self.hue, self.matrix, self.mean_in, self.mean_out = lightness, hue, matrix, mean_in, mean_out

    @classmethod
    def fit(cls, painting: Tensor, style: Tensor) -> Recoloring:
        """The start: the chroma of ``painting`` (3, H, W) carried onto ``style``'s (3, h, w), both
        RGB in [0, 1], by the Gaussian transport map; the lightness kept."""
        p = rgb_to_lab(painting.detach().flatten(1).cpu().double(), dim=0)[1:]  # (2, N); a 2×2 fit: on the CPU
        s = rgb_to_lab(style.detach().flatten(1).cpu().double(), dim=0)[1:]  # (2, M)
        transport = gaussian_transport(torch.cov(p) + EPS * torch.eye(2, dtype=p.dtype), torch.cov(s))
        values, vectors = torch.linalg.eigh(transport)
        matrix = vectors @ torch.diag(values.clamp(max=STRETCH)) @ vectors.T
        return cls(torch.linspace(0, 1, KNOTS + 1), torch.zeros(KNOTS + 1, 2), matrix.float(), p.mean(1).float(),
                   s.mean(1).float())

    def refine(self, painting: Tensor, photo: Tensor, style: Tensor, floor: float, bound: float,
               seed: int = 0) -> Recoloring:
        """This map refined so that ``painting`` (3, H, W) takes ``style``'s colours (3, h, w): its
        sliced Wasserstein distance to them falls, while its luminance SSIM to ``photo`` (3, H, W)
        stays ≥ ``floor`` and colours within :data:`~nsp.style.measures.NEAR` of each other in it end
        up ≤ ``bound`` apart on average (RGB), each aimed :data:`MARGIN` inside; all RGB in [0, 1].
        g and A vary the chroma only in the directions the style's does (:func:`chroma_span`): toward
        a grey style the painting stays grey. :data:`STEPS` Adam steps on the painting's pixels,
        their draws seeded by ``seed``."""
        generator = torch.Generator().manual_seed(seed)
        height, width = painting.shape[1:]
        colors = painting.detach().cpu().float().flatten(1).T  # (N, 3)
        lab = rgb_to_lab(colors)
        styles = rgb_to_lab(style.detach().cpu().float().flatten(1).T)
        styles = styles[torch.randperm(len(styles), generator=generator)[:PIXELS]].T[None, :, :, None]  # (1, 3, M, 1)
        compared = torch.randperm(len(lab), generator=generator)[:PIXELS]
        first, second = alike_pairs(colors, PAIRS, generator)
        photo_lightness = rgb_to_lab(photo.detach().cpu().float(), dim=0)[:1]
        span = chroma_span(style)
        floor, bound = floor + MARGIN * (1 - floor), (1 - MARGIN) * bound

        slope = (self.lightness.diff() * KNOTS / STRETCH).clamp(1e-3, 1 - 1e-3)
        logits = torch.logit(slope).requires_grad_(True)  # f's slope, STRETCH·sigmoid: increasing, ≤ STRETCH
        start = self.lightness[:1].clone().requires_grad_(True)
        hue, matrix = self.hue.clone().requires_grad_(True), self.matrix.clone().requires_grad_(True)
        optimizer = torch.optim.Adam([{"params": [logits, start, matrix]}, {"params": [hue], "lr": HUE_RATE}], lr=RATE)
        schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, STEPS)

        def current() -> Recoloring:
            values = torch.cat([start, start + torch.cumsum(STRETCH * torch.sigmoid(logits) / KNOTS, 0)])
            return Recoloring(values, hue @ span.T, span @ matrix, self.mean_in, self.mean_out)

        def objective(draws: torch.Generator, projections: int) -> Tensor:
            rgb = lab_to_rgb(current().lab(lab)).clamp(0, 1)  # as painted
            out = rgb_to_lab(rgb)
            distance = sliced_wasserstein(out[compared].T[None, :, :, None], styles, projections, draws)
            structure = ssim(out[:, 0].reshape(1, height, width), photo_lightness)
            spread = parted(rgb.T, first, second) if len(first) else torch.zeros(())
            return distance + PENALTY * (F.relu(floor - structure) + F.relu(spread - bound))

        def judged() -> tuple[float, Recoloring]:
            """The objective on the same directions at every check, and a copy of the map."""
            with torch.no_grad():
                score = float(objective(torch.Generator().manual_seed(seed), JUDGE))
                kept = current()
                return score, Recoloring(kept.lightness, kept.hue.clone(), kept.matrix.clone(), self.mean_in, self.mean_out)

        best = judged()  # the start: refining never returns a worse map by its own measure
        for step in range(1, STEPS + 1):
            loss = objective(generator, PROJECTIONS)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            schedule.step()
            if step % CHECK == 0:
                best = min(best, judged(), key=lambda scored: scored[0])
        return best[1]

    def matched_tones(self, painting: Tensor, style: Tensor) -> Recoloring:
        """This map with f the increasing map that carries ``painting``'s lightness quantiles onto
        ``style``'s (1-D optimal transport, histogram matching), sampled at the knots; RGB (3, H, W)
        and (3, h, w) in [0, 1]. :meth:`toward` it is displacement interpolation of the tones."""
        own, their = (rgb_to_lab(x.detach().flatten(1).cpu().double(), dim=0)[0].sort().values for x in (painting, style))
        rank = torch.searchsorted(own, torch.linspace(0, 1, KNOTS + 1, dtype=own.dtype)) / len(own)  # the CDF at the knots
        tones = their[(rank * (len(their) - 1)).round().long()].float()
        return Recoloring(tones, self.hue, self.matrix, self.mean_in, self.mean_out)

    def toward(self, other: Recoloring, share: float) -> Recoloring:
        """The map ``share`` ∈ [0, 1] of the way from this one to ``other`` (same means), parameter by
        parameter; f stays increasing."""
        def mix(a: Tensor, b: Tensor) -> Tensor:
            return (1 - share) * a + share * b

        return Recoloring(mix(self.lightness, other.lightness), mix(self.hue, other.hue),
                          mix(self.matrix, other.matrix), self.mean_in, self.mean_out)

    def lab(self, lab: Tensor) -> Tensor:
        """Recoloured L*a*b* / 100 colours (..., 3), possibly outside the sRGB gamut."""
        weights = _hat(lab[..., 0])
        chroma = self.mean_out.to(lab) + (lab[..., 1:] - self.mean_in.to(lab)) @ self.matrix.to(lab).T
        return torch.cat([(weights @ self.lightness.to(lab))[..., None], chroma + weights @ self.hue.to(lab)], -1)

    def __call__(self, rgb: Tensor, dim: int = -1) -> Tensor:
        """Recoloured ``rgb`` in [0, 1], channels along ``dim`` (any shape); out of gamut: clamped."""
        return lab_to_rgb(self.lab(rgb_to_lab(rgb, dim).movedim(dim, -1))).clamp(0, 1).movedim(-1, dim)

    def strokes(self, brush: Brush, x: Tensor) -> Tensor:
        """Strokes (N, d) with every colour (each RGB triple of ``brush.color``) recoloured; all
        other parameters bit for bit."""
        color = list(brush.color)
        out = x.detach().clone()
        out[:, color] = self(x.detach()[:, color].reshape(len(x), -1, 3)).reshape(len(x), -1)
        return out


def chroma_span(style: Tensor) -> Tensor:
    """The projection (2, 2) onto the directions of chroma (a*, b*) in which the colours of ``style``
    (3, h, w) vary by :data:`HUED` or more: the identity for a colourful style, zero for a grey one.

    A sliced Wasserstein fit may otherwise tint the tones a grey style cannot match in lightness:
    along a direction that mixes lightness and chroma, a hue makes up part of the lightness gap.
    """
    chroma = rgb_to_lab(style.detach().flatten(1).cpu().double(), dim=0)[1:]
    values, vectors = torch.linalg.eigh(torch.cov(chroma))
    varied = values.clamp(min=0).sqrt() >= HUED
    if varied.all():
        return torch.eye(2)
    kept = vectors[:, varied]
    return (kept @ kept.T).float()


def _hat(lightness: Tensor) -> Tensor:
    """The weights (..., KNOTS + 1) of the knots L = 0, 1/KNOTS, …, 1 that interpolate linearly at
    ``lightness`` (...), clamped to [0, 1]."""
    position = lightness.clamp(0, 1) * KNOTS
    index = position.floor().clamp(max=KNOTS - 1)
    frac = (position - index)[..., None]
    below = F.one_hot(index.long(), KNOTS + 1).to(lightness)
    return (1 - frac) * below + frac * below.roll(1, -1)


def gaussian_transport(source: Tensor, target: Tensor) -> Tensor:
    """The optimal transport map's matrix between centred Gaussians of covariances ``source`` and
    ``target`` (k, k): Σ₀^-½ (Σ₀^½ Σ₁ Σ₀^½)^½ Σ₀^-½, symmetric positive semi-definite."""
    root = psd_sqrt(source)
    inverse = torch.linalg.inv(root)
    return inverse @ psd_sqrt(root @ target @ root) @ inverse


def psd_sqrt(matrix: Tensor) -> Tensor:
    """The square root of a symmetric positive semi-definite matrix (k, k)."""
    values, vectors = torch.linalg.eigh((matrix + matrix.T) / 2)
    return vectors @ torch.diag(values.clamp(min=0).sqrt()) @ vectors.T
