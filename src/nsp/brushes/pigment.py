"""Wet media's pigment (watercolor, marker ink): where a stroke lays more pigment, it is darker.

The pigment's density ρ over a stroke (mean 1) darkens or lightens its colour C as Bousseau et al.
(2006) do, C' = C − C(1 − C)(ρ − 1): linear in ρ, so a stroke's mean colour stays its own. The painter,
working small, optimizes that mean (each brush's ``plain`` form, ρ ≡ 1); files draw ρ where the canvas
is wide enough to show it, like oil's bristles.

- **Watercolor**: pigment pools at a wash's rim as it dries (edge darkening: ρ rises over the outer
  ``EDGE`` of the radius, the middle a little paler; on washes wider than ``RIM_FROM``), and settles
  into the paper's hollows (granulation). The paper is value noise fixed on the canvas, the same under
  every stroke, its grain ``PAPER`` canvas widths across: a larger render shows finer grain, never
  magnified texels; a grain too fine for the canvas is its mean.
- **Marker pen**: a felt nib lays streaks along its path (value noise ``STREAK`` canvas widths
  across, ``STRETCH`` times longer along the stroke, drawn per stroke from its key), and ink pools
  where the nib rests, at both ends (within ``POOL`` half-widths of them).

The strengths are as large as the painter's score allows: at 500 strokes on the six built-in photos,
the look costs 0.25 dB (watercolor) and 0.1 dB (marker pen) of PSNR against the photo (docs/brushes.md)."""
from __future__ import annotations

import functools
import math

import torch
from torch import Tensor

from nsp.brushes.noise import NOISE_STD, drawn, ramp, seen, value_noise

PAPER = (1 / 384, 1 / 768, 1 / 1536)  # the grain's cells, in canvas widths: 2.7 to 0.7 px at 1024, 10.7 to 2.7 at 4096
PAPER_SHARE = (0.25, 1.0, 0.8)  # each scale's share of the grain's amplitude
GRANULATION = 0.15  # ρ's standard deviation from the grain, every scale drawn
EDGE = 0.1  # the rim's width, a fraction of the radius
RIM_FROM = (0.035, 0.07)  # radii (canvas widths) over which the rim grows from none to full
RIM = 0.75  # ρ at the edge is 1 + RIM·(1 − the profile's mean), at the middle 1 − RIM·(the mean)
STREAK = (1 / 800, 1 / 1600)  # the marker's streaks (fibre bundles, fibres), canvas widths across: 5.1 and 2.6 px at 4096
STREAK_SHARE = (1.0, 0.6)
STREAKS = 0.08  # ρ's standard deviation from the streaks, both scales drawn
STRETCH = 50.0  # streak cells are this many times longer along the stroke than across
POOL = 0.8  # ink pools within this many half-widths of an end
POOLING = 0.1  # ρ at an end's pool, above the stroke's mean
POOLED = 1 / 200  # a stroke this many canvas widths wide, whose pools decide where pools are drawn
_PAPER_SEED = 0x5BD1E995  # one sheet of paper under every painting


def tint(color: Tensor, density: Tensor) -> Tensor:
    """Colour (P, 3, N) in [0, 1] laid with pigment ``density`` (P, N), 1 its own: (P, 3, N) in [0, 1]."""
    return (color - color * (1 - color) * (density - 1)[:, None]).clamp(0, 1)


@functools.cache  # asked at every render
def wash_parts(scale: float) -> tuple[bool, ...]:
    """Which parts of a wash a canvas ``scale`` px wide draws: its rim (where the widest rims span
    pixels), then each of the paper's :data:`PAPER` scales."""
    return drawn((EDGE * RIM_FROM[1],) + PAPER, scale)


def octaves(px: Tensor, py: Tensor, cells: tuple[float, ...], shares: tuple[float, ...], seed: Tensor | int,
            width: int | Tensor, parts: tuple[bool, ...]) -> Tensor:
    """Value noise summed over scales of ``cells`` canvas widths, each its ``share`` of the amplitude,
    at pixels (px, py) (P, N) of a canvas ``width`` px wide, knots from ``seed`` ((P, 1) or an int): mean
    0, standard deviation 1 where every scale is drawn (``parts``), each scale fading out as it
    shrinks below two pixels (:func:`~nsp.brushes.noise.seen`): (P, N)."""
    total = math.sqrt(sum(share**2 for share in shares)) * NOISE_STD
    height = torch.zeros_like(px)
    for k, (cell, share, part) in enumerate(zip(cells, shares, parts)):
        if part:
            pixels = px.new_ones(()) * (cell * width)  # made on px's device, not copied in
            value, _ = value_noise(px / pixels, py / pixels, seed + k * 0x61C88647)
            height = height + seen(pixels) * share / total * (value - 0.5)
    return height


def rim(inside: Tensor, radius: Tensor, width: int | Tensor) -> Tensor:
    """Edge darkening: ρ at pixels ``inside`` px outside a disc of ``radius`` px (P, N), over a rim
    :data:`EDGE` of the radius wide, or a pixel where that is less (so that pixels sample it); its
    mean over a stroke's cross-section, where the depth into it is uniform, is 1."""
    edge = torch.maximum(EDGE * radius, torch.ones_like(radius))
    fraction = edge / radius.clamp(min=0.5)
    mean = fraction * (1 - torch.exp(-1 / fraction))
    return 1 + RIM * ramp(RIM_FROM[0], RIM_FROM[1], radius / width) * (torch.exp(-(-inside).clamp(min=0) / edge) - mean)


def wash(inside: Tensor, radius: Tensor, px: Tensor, py: Tensor, width: int | Tensor,
         parts: tuple[bool, ...]) -> Tensor | None:
    """The pigment's density ρ (P, N) of a watercolor wash at pixels (px, py) (P, N) ``inside`` px
    outside its swept disc of ``radius`` (P, N) px, on a canvas ``width`` px wide: its rim and the
    paper's grain, as ``parts`` draws them (:func:`wash_parts`); None where it draws neither."""
    edge, *paper = parts
    density = rim(inside, radius, width) if edge else None
    if any(paper):
        grain = 1 + GRANULATION * octaves(px, py, PAPER, PAPER_SHARE, _PAPER_SEED, width, paper)
        density = grain if density is None else density * grain
    return density


@functools.cache  # asked at every render
def streak_parts(scale: float) -> tuple[bool, ...]:
    """Which parts of a marker stroke a canvas ``scale`` px wide draws: its pools (where those of a
    stroke :data:`POOLED` canvas widths wide span pixels), then each of its :data:`STREAK` scales."""
    return drawn((POOL * POOLED,) + STREAK, scale)


def marker(along: Tensor, across: Tensor, length: Tensor, half: Tensor, key: Tensor, width: int | Tensor,
           parts: tuple[bool, ...]) -> Tensor:
    """A marker stroke's density ρ (P, N) at pixels ``along`` px from its start (0 to ``length``, (P, 1))
    and ``across`` px off its path, its half width ``half`` (P, 1) px, keyed ``key`` (P, 1), its ``parts``
    drawn (:func:`streak_parts`): its pools at both ends (mean 1 over the stroke) and its streaks."""
    pooled, *streaks = parts
    density = torch.ones_like(along)
    if pooled:
        reach = POOL * half.clamp(min=0.5)
        pools = torch.exp(-along.clamp(min=0) / reach) + torch.exp(-(length - along).clamp(min=0) / reach)
        density = density + POOLING * (pools - 2 * reach / length.clamp(min=1e-3) * (1 - torch.exp(-length / reach)))
    if any(streaks):
        density = density + STREAKS * octaves(across, along / STRETCH, STREAK, STREAK_SHARE, key, width, streaks)
    return density
