"""Colour mode (paper §3.5): a painting's colours moved toward a style image's, its shapes kept.

Two fits lower the sliced Wasserstein distance to the style's colours (:class:`Objective`) within two
promises (:class:`Bounds`: the photo's luminance structure still reads, colours alike stay alike): first
one map in L*a*b* shared by every stroke and the canvas colour (:class:`Recoloring`: lightness kept in
order, so edges stay edges; chroma from the Gaussian optimal transport map, then fitted on the painting's
pixels), then each stroke's colours on their own along the style's spread (:func:`refine_strokes`). Each
fit is checked on the painted strokes (where translucent strokes blend, a curved map's blend is not the
map of the blend) and, past a bound, taken back toward its start a share at a time (:func:`within_bounds`).
:class:`ColorSettings`'s knobs were chosen on ``experiment=style_dev`` (docs/style.md).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import hex_color, lab_to_rgb, parse_color, rgb_to_lab
from nsp.engine import paint_canvas
from nsp.images import ssim
from nsp.style.losses import sliced_wasserstein
from nsp.style.measures import SAMPLES, alike_pairs, luminance_ssim, parted

KNOTS = 16  # f and g are linear on each of KNOTS equal pieces of L ∈ [0, 1]
STRETCH = 2.0  # the most the map stretches chroma differences (A's largest eigenvalue) and f's slope
EPS = 1e-4  # added to the painting's chroma covariance, (1 ΔE)²: a grey painting's stays invertible
HUED = 0.005  # a direction of chroma in which the style's colours vary less (0.5 ΔE) takes no hue
PIXELS = 2048  # seeded pixels of the painting and of the style a fit's step compares
PAIRS = 20000  # the alike pairs a fit's step holds together, drawn afresh
PROJECTIONS = 32  # sliced Wasserstein directions a fit's step draws
JUDGE = 256  # the fixed directions on which a fit's result is compared with its start
PENALTY = 10.0  # a bound's excess against the (relative) colour distance


@dataclass(frozen=True)
class ColorSettings:
    """Colour mode's knobs, each defaulted here alone; docs/style.md says how they were chosen."""

    structure: float = 0.2  # the share of the plain painting's luminance SSIM given up per unit of β_sty
    coherence: float = 0.05  # the most colours alike in the plain painting (within 0.03 RGB) may part on average
    margin: float = 0.05  # the fits aim this share inside each bound
    map_steps: int = 150  # Adam steps of the shared map on the painting's pixels
    map_rate: float = 0.05  # their learning rate (L*a*b* / 100), cosine-annealed to 0
    stroke_steps: int = 100  # Adam steps of each stroke's colours; 0: the shared map alone
    stroke_rate: float = 0.08  # their learning rate, in the style's standard deviations
    back: int = 10  # a fit past a bound goes back toward its start 1/back of the way at a time


class Bounds:
    """Colour mode's two promises about a recoloured painting (3, H, W) of ``photo``: its luminance SSIM
    to the photo ≥ ``floor`` = (1 − structure·β) × the ``plain`` painting's, and the pixels alike in ``plain``
    (:func:`~nsp.style.measures.alike_pairs`, seeded by ``seed``) within ``settings.coherence`` on average."""

    def __init__(self, plain: Tensor, photo: Tensor, weight: float, settings: ColorSettings, seed: int):
        self.photo, self.settings = photo, settings
        self.lightness = rgb_to_lab(photo.float(), dim=0)[:1]
        self.floor = (1 - settings.structure * weight) * luminance_ssim(plain, photo)
        self.first, self.second = alike_pairs(plain.flatten(1).T.float(), SAMPLES, torch.Generator().manual_seed(seed))

    def hold(self, image: Tensor) -> bool:
        """Whether ``image`` keeps both (no alike pair at all: nothing to part)."""
        apart = parted(image, self.first, self.second)
        return luminance_ssim(image, self.photo) >= self.floor and not apart > self.settings.coherence

    def excess(self, image: Tensor, generator: torch.Generator) -> Tensor:
        """How far ``image`` lies past either bound aimed ``margin`` inside, on :data:`PAIRS` drawn
        pairs: differentiable, 0 well within."""
        margin = self.settings.margin
        structure = ssim(rgb_to_lab(image, dim=0)[:1], self.lightness)
        excess = F.relu(self.floor + margin * (1 - self.floor) - structure)
        if len(self.first):
            pick = torch.randint(len(self.first), (min(len(self.first), PAIRS),), generator=generator)
            excess = excess + F.relu(parted(image, self.first[pick], self.second[pick]) - (1 - margin) * self.settings.coherence)
        return excess


class Objective:
    """What both fits lower: the sliced Wasserstein distance in L*a*b* / 100 between a painting's
    colours and ``style``'s (3, h, w), relative to the ``plain`` painting's, plus :data:`PENALTY` ×
    the :class:`Bounds`' excess; ``tick`` is called at each step (a progress bar)."""

    def __init__(self, plain: Tensor, style: Tensor, bounds: Bounds, seed: int, tick: Callable[[], None] | None = None):
        self.bounds, self.seed, self.tick = bounds, seed, tick
        self.generator = torch.Generator().manual_seed(seed + 1)
        self.style = rgb_to_lab(style.float(), dim=0).flatten(1)
        self.sampled = self.style[:, torch.randperm(self.style.shape[1], generator=self.generator)[:PIXELS]]
        self.scale = max(self.distance(plain), 1e-6)  # 0: the style's own colours

    def __call__(self, image: Tensor) -> Tensor:
        """A step's loss: :data:`PIXELS` fresh pixels of ``image`` (3, H, W) on fresh directions."""
        lab = rgb_to_lab(image.flatten(1), dim=0)
        pixels = lab[:, torch.randperm(lab.shape[1], generator=self.generator)[:PIXELS]]
        distance = sliced_wasserstein(pixels[None, :, :, None], self.sampled[None, :, :, None], PROJECTIONS, self.generator)
        if self.tick is not None:
            self.tick()
        return distance / self.scale + PENALTY * self.bounds.excess(image, self.generator)

    def distance(self, image: Tensor) -> float:
        """The distance of every pixel, on :data:`JUDGE` directions fixed by the seed: how fits are judged."""
        with torch.no_grad():
            lab = rgb_to_lab(image.float().flatten(1), dim=0)
            generator = torch.Generator().manual_seed(self.seed)
            return float(sliced_wasserstein(lab[None, :, :, None], self.style[None, :, :, None], JUDGE, generator))


def recolor(brush: Brush, strokes: Tensor, photo: Tensor, style: Tensor, weight: float, background: str,
            seed: int, settings: ColorSettings = ColorSettings(), tick: Callable[[], None] | None = None) -> tuple[Tensor, str]:
    """Colour mode: ``strokes`` (N, d), a painting of ``photo`` (3, H, W) on ``background``,
    recoloured toward ``style`` (3, h, w), all RGB in [0, 1], β_sty = ``weight`` (0: the shared
    map's start alone, which keeps the lightness). Returns the strokes, shapes bit for bit, and the
    canvas colour as ``#rrggbb``; the fits' draws are seeded by ``seed``, and each of their steps calls ``tick``."""
    height, width = photo.shape[1:]
    with torch.no_grad():
        plain = paint_canvas(brush, strokes, height, width, background)
    bounds = Bounds(plain, photo, weight, settings, seed) if weight > 0 else None
    shared = shared_map(brush, strokes, plain, photo, style, weight, background, seed, settings, tick, bounds)
    x, canvas = shared.strokes(brush, strokes), shared(torch.tensor(parse_color(background)))
    if bounds is not None and settings.stroke_steps:
        x, canvas = refine_strokes(brush, x, canvas, style, Objective(plain, style, bounds, seed, tick), settings)
    return x, hex_color(canvas)


def shared_map(brush: Brush, strokes: Tensor, plain: Tensor, photo: Tensor, style: Tensor, weight: float,
               background: str, seed: int, settings: ColorSettings = ColorSettings(),
               tick: Callable[[], None] | None = None, bounds: Bounds | None = None) -> Recoloring:
    """The map shared by every stroke of ``strokes`` (N, d) and by the canvas colour: fitted on the ``plain``
    painting's pixels (3, H, W, of ``photo`` on ``background``), then the largest share of the way from its
    start that keeps the :class:`Bounds` (``bounds`` if given) on the painted strokes. ``weight`` 0: the start."""
    start = Recoloring.fit(plain, style)
    if weight == 0:
        return start
    bounds = Bounds(plain, photo, weight, settings, seed) if bounds is None else bounds
    objective = Objective(plain, style, bounds, seed, tick)
    fitted = start.refine(plain, objective, settings)
    height, width = plain.shape[1:]

    def painted(share: float) -> tuple[Recoloring, Tensor]:
        recoloring = start.toward(fitted, share)
        canvas = recoloring(torch.tensor(parse_color(background)))
        return recoloring, paint_canvas(brush, recoloring.strokes(brush, strokes), height, width,
                                        parse_color(hex_color(canvas)))

    return within_bounds(painted, bounds, objective, settings.back) or start


def within_bounds(painted: Callable[[float], tuple[object, Tensor]], bounds: Bounds, objective: Objective,
                  back: int) -> object | None:
    """Of a fit's results ``painted(share)`` -> (result, its painting (3, H, W)), share 1 the fit
    and 0 its start: the largest share of 1, 1 − 1/``back``, …, 1/``back`` whose painting keeps the
    ``bounds``, if it lies nearer the style than the start's; else None (the start stands)."""
    with torch.no_grad():
        start = objective.distance(painted(0.0)[1])
        for share in range(back, 0, -1):
            result, image = painted(share / back)
            if bounds.hold(image):
                return result if objective.distance(image) < start else None
    return None


def refine_strokes(brush: Brush, strokes: Tensor, canvas: Tensor, style: Tensor, objective: Objective,
                   settings: ColorSettings) -> tuple[Tensor, Tensor]:
    """Every colour of the painting ``strokes`` (N, d) on the canvas colour ``canvas`` (3,) moved on its own
    by an L*a*b* offset Σ½·u, Σ the style's colour covariance (strokes part only where the style's colours
    vary), ``stroke_steps`` Adam steps on the painted canvas lowering ``objective``; then
    :func:`within_bounds`. Returns the strokes (shapes bit for bit) and the canvas colour (3,)."""
    height, width = objective.bounds.photo.shape[1:]
    index = list(brush.color)
    start = torch.cat([strokes[:, index].reshape(-1, 3), canvas[None].to(strokes)]).float()  # (K, 3): strokes', canvas
    lab = rgb_to_lab(start)
    spread = psd_sqrt(torch.cov(objective.style.double()) + 1e-8 * torch.eye(3, dtype=torch.float64)).float()
    offsets = torch.zeros_like(start, requires_grad=True)
    optimizer = torch.optim.Adam([offsets], lr=settings.stroke_rate)

    def colored(share: float | Tensor) -> tuple[Tensor, Tensor]:
        table = lab_to_rgb(lab + share * offsets @ spread.T).clamp(0, 1)
        x = strokes.detach().clone()
        x[:, index] = table[:-1].reshape(len(x), -1).to(x)
        return x, table[-1]

    def paint(x: Tensor, color: Tensor) -> Tensor:
        return paint_canvas(brush, x, height, width, canvas=color[:, None, None].expand(3, height, width))

    for _ in range(settings.stroke_steps):
        x, color = colored(1.0)
        loss = objective(paint(x, color))
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()

    def painted(share: float) -> tuple[tuple[Tensor, Tensor], Tensor]:
        x, color = colored(share)
        x, color = x.detach(), torch.tensor(parse_color(hex_color(color)))  # the canvas colour as the files write it
        return (x, color), paint(x, color)

    kept = within_bounds(painted, objective.bounds, objective, settings.back)
    return kept if kept is not None else (strokes, canvas)


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
        """The start: the chroma of ``painting`` (3, H, W) carried onto ``style``'s (3, h, w) by the
        optimal transport map between their Gaussian approximations, its stretch capped at
        :data:`STRETCH` (a drab painting's near-alike colours are not pulled apart); the lightness kept."""
        p = rgb_to_lab(painting.detach().flatten(1).cpu().double(), dim=0)[1:]  # (2, N); a 2×2 fit: on the CPU
        s = rgb_to_lab(style.detach().flatten(1).cpu().double(), dim=0)[1:]  # (2, M)
        transport = gaussian_transport(torch.cov(p) + EPS * torch.eye(2, dtype=p.dtype), torch.cov(s))
        values, vectors = torch.linalg.eigh(transport)
        matrix = vectors @ torch.diag(values.clamp(max=STRETCH)) @ vectors.T
        return cls(torch.linspace(0, 1, KNOTS + 1), torch.zeros(KNOTS + 1, 2), matrix.float(), p.mean(1).float(),
                   s.mean(1).float())

    def refine(self, painting: Tensor, objective: Objective, settings: ColorSettings) -> Recoloring:
        """This map with f, g and A fitted so that ``painting`` (3, H, W) recoloured lowers
        ``objective``: ``map_steps`` Adam steps on its pixels. f stays increasing with slope ≤
        :data:`STRETCH`; g and A vary the chroma only where the style's colours vary (:func:`chroma_span`)."""
        span = chroma_span(objective.style)
        slope = (self.lightness.diff() * KNOTS / STRETCH).clamp(1e-3, 1 - 1e-3)
        logits = torch.logit(slope).requires_grad_(True)  # f's slope, STRETCH·sigmoid: increasing, ≤ STRETCH
        start = self.lightness[:1].clone().requires_grad_(True)
        hue, matrix = self.hue.clone().requires_grad_(True), self.matrix.clone().requires_grad_(True)
        optimizer = torch.optim.Adam([{"params": [logits, start, matrix]}, {"params": [hue], "lr": settings.map_rate / 10}],
                                     lr=settings.map_rate)  # g's tenth: near black, a step of chroma leaves the gamut
        schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, max(settings.map_steps, 1))

        def current() -> Recoloring:
            values = torch.cat([start, start + torch.cumsum(STRETCH * torch.sigmoid(logits) / KNOTS, 0)])
            return Recoloring(values, hue @ span.T, span @ matrix, self.mean_in, self.mean_out)

        plain = painting.detach().float()
        for _ in range(settings.map_steps):
            loss = objective(current()(plain, dim=0))
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            schedule.step()
        with torch.no_grad():
            return current()

    def toward(self, other: Recoloring, share: float) -> Recoloring:
        """The map ``share`` ∈ [0, 1] of the way from this one to ``other`` (same means), parameter
        by parameter; f stays increasing."""
        pairs = ((self.lightness, other.lightness), (self.hue, other.hue), (self.matrix, other.matrix))
        return Recoloring(*((1 - share) * a + share * b for a, b in pairs), self.mean_in, self.mean_out)

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
    """The projection (2, 2) onto the directions of chroma (a*, b*) in which the colours ``style``
    (3, M, L*a*b* / 100) vary by :data:`HUED` or more: the identity for a colourful style, zero for
    a grey one (a sliced fit may otherwise tint the tones a grey style cannot match in lightness)."""
    values, vectors = torch.linalg.eigh(torch.cov(style[1:].double()))
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
