"""The oil brush's bristle model: paint laid by a brush of bristles, evaluated at every pixel.

The paint's thickness over a stroke is a height field H: value noise stretched ``STRETCH`` times along
the stroke (bristle streaks), summed over four scales from clumps of bristles (three track widths) to
fibres (a sixth of one), each a fixed width in canvas units (``TRACK`` canvas widths a track): a large
stroke carries more streaks than a small one, a larger render finer ones, never magnified texels. A
scale too fine to be seen is its mean (like a mipmap): the painter, working small, sees the mean paint.

- **Load**: paint covers a fraction 1 − D, where H exceeds a threshold set by the dryness D, which
  rises toward the tail (dry brush) and the sides (ragged edges); undrawn scales blur the threshold.
- **Head**: rounded, and ragged where the brush is several tracks wide; a dab of a few tracks touches down
  round and whole, as the tip of a small brush does. The tail's outer streaks end early (a taper).
- **Impasto**: H's slope across the stroke, lit from the upper left: lighter facing the light,
  darker away (the mean colour is the stroke's); thicker streaks are a little darker too. The paint's
  body swells to the stroke's middle by a height of its own (``BODY``), so a dab's slopes are steep and
  lit, a raised mark, and a wide stroke's a gentle swell.

Randomness: an integer hash of the stroke's key (its index and the painting's seed) and the lattice
cell: deterministic, different for every stroke, identical at every render size."""
from __future__ import annotations

import functools
import math
from typing import NamedTuple

import torch
from torch import Tensor

from nsp.brushes.noise import NOISE_STD, drawn, ramp, seen, value_noise

TRACK = 1 / 480  # a bristle track's width, in canvas widths (2.1 px at 1024, 8.5 px at 4096)
SCALES = (3.0, 1.0, 0.4, 0.16)  # the noise's cells across, in tracks: clumps, tracks, fibres
GRAIN = (0.2, 0.6, 0.4, 0.25)  # each scale's share of the height H, which the load and the streaks follow
STRETCH = 5.0  # cells are this many times longer along the stroke than across
TAIL = (0.7, 0.7)  # dryness from 70 % of the way to the tail: none → 70 %
SIDES = (0.9, 0.3)  # the outer tenth of the stroke's height: up to 30 % dry (ragged edges)
ROUND = 0.6  # the head's rounding radius, a fraction of the stroke's half height (a dab's: all of it)
RAGGED = 4.0  # how far a track's start may stray from the head's curve, in track widths (≤ 20 % of the length)
DAB = (1.5, 4.0)  # a stroke's half height in tracks: up to the first a dab (round head, whole), ragged from the second
BODY = 0.35  # the paint's swell at a stroke's middle above its sides, in the relief's units per track
TAPER = 0.5  # the tail's outer streaks end this fraction of the half height early
STREAKS = 0.03  # thicker paint is darker by this much per standard deviation of H
SHARP = 0.15  # the least blur of the threshold, in standard deviations of H (antialiasing)
LIGHT = (-1 / math.sqrt(2), -1 / math.sqrt(2))  # toward the light, on screen (x right, y down)
RELIEF = (0.15, 0.5, 0.3, 0.08)  # each scale's share of the relief: its ridges lit, clumps' barely
LIT = 0.35  # the change of the paint's lightness per unit of slope toward the light


@functools.cache  # asked at every render
def detail(scale: float) -> tuple[bool, ...]:
    """Which of the model's parts are drawn on a canvas ``scale`` px wide: the tracks' ragged starts,
    then each of :data:`SCALES` (:func:`~nsp.brushes.noise.drawn`); none: the model's mean.
    Widths with the same parts share one compiled kernel (:func:`nsp.engine.kernels.shade_any_size`)."""
    scales = drawn(tuple(cells * TRACK for cells in SCALES), scale)
    track = torch.tensor(TRACK * scale, dtype=torch.float64, device="cpu")  # a number, not a pixel
    return (bool(seen(track) > 0) and any(scales), *scales)


def light_across(theta: Tensor) -> tuple[Tensor, Tensor]:
    """The light's direction in a stroke's frame (along, across), for its angle θ (P,): (P, 1) each."""
    angle = theta * math.pi
    cos, sin = torch.cos(angle)[:, None], torch.sin(angle)[:, None]
    return LIGHT[0] * cos + LIGHT[1] * sin, -LIGHT[0] * sin + LIGHT[1] * cos


class Surface(NamedTuple):
    """Paint on a stroke's pixels: ``cover`` in [0, 1], the alpha inside the stroke's ``outline`` (a
    signed distance in px, negative inside); its colour, the stroke's times ``shade`` (None: 1, no
    detail drawn), linear in the stroke's colours as colour mode's recolouring needs. (P, N) each."""

    cover: Tensor
    shade: Tensor | None
    outline: Tensor


def surface(s: Tensor, c: Tensor, u: Tensor, length: Tensor, half_h: Tensor, key: Tensor, scale: float | Tensor,
            light: tuple[Tensor, Tensor] | None, parts: tuple[bool, ...]) -> Surface:
    """The bristle model at pixels ``s`` px from the head (``u`` = s / length in [0, 1]) and ``c`` px
    across the centre line (P, N), of strokes ``length`` px long and 2·``half_h`` px high (P,), keyed
    ``key`` (P, 1), on a canvas ``scale`` px wide (a 0-d tensor in a kernel of any size), its ``parts``
    drawn (:func:`detail`); ``light`` from :func:`light_across` (None: no impasto)."""
    half_h = half_h.clamp(min=0.5)[:, None]
    side = (c / half_h).abs().clamp(max=1)
    dry = 1 - (1 - TAIL[1] * ramp(TAIL[0], 1.0, u)) * (1 - SIDES[1] * ramp(SIDES[0], 1.0, side))
    width = s.new_ones(()) * (TRACK * scale)  # a track, in pixels: a 0-d tensor made on s's device, not copied in
    ragged = ramp(DAB[0], DAB[1], half_h / width)  # 0 for a dab, 1 for a stroke several tracks wide
    radius = torch.minimum((1 - (1 - ROUND) * ragged) * half_h, 0.5 * length[:, None])
    squared = side * side
    head = radius * (1 - torch.sqrt((1 - squared).clamp(min=1e-6))) - s  # the head's rounded corners
    tail = s - (length[:, None] - TAPER * half_h * squared)  # the tail's tapered ones
    tracks, *scales = parts
    if not any(scales):  # nothing drawn: the mean of the model
        return Surface(1 - dry, None, torch.maximum(head, tail))
    if tracks:
        jag, _ = value_noise(c / width, torch.zeros_like(c), key + 0x2F6B2E1D)  # each track starts a little early or late
        head = head + seen(width) * ragged * torch.minimum(0.2 * length[:, None], RAGGED * width) * (jag - 0.5)
    outline = torch.maximum(head, tail)
    height, unseen = 0, 0.0  # unseen: the variance of H left undrawn
    # The body's slope, per track: BODY·(1 − (c / half_h)²) differentiated, no steeper than a track-high stroke's.
    slope = -2 * BODY * width * (c / half_h).clamp(-1, 1) / torch.maximum(half_h, width)
    for k, (cells, grain, relief, drawn) in enumerate(zip(SCALES, GRAIN, RELIEF, scales)):
        cell = cells * width  # pixels
        weight = seen(cell)
        unseen = unseen + (1 - weight**2) * (grain * NOISE_STD) ** 2
        if drawn:
            value, rise = value_noise(c / cell, s / (STRETCH * cell), key + k * 0x61C88647)
            height = height + weight * grain * (value - 0.5)
            slope = slope + weight * relief / cells * rise
    spread = math.sqrt(sum((g * NOISE_STD) ** 2 for g in GRAIN))
    # P(H > level) = 1 − D, and the scales left undrawn (taken as Gaussian) blur the threshold: the
    # cover expected over them, so its mean is the same at every size.
    level = spread * math.sqrt(2) * torch.erfinv((2 * dry - 1).clamp(-0.998, 0.998))
    blur = unseen.sqrt().clamp(min=SHARP * spread)
    cover = 0.5 * (1 + torch.erf((height - level) / (blur * math.sqrt(2))))
    shade = 1 - STREAKS * height / spread
    if light is not None:  # Lambert's law for small slopes: lighter facing the light, darker away; mean 1
        shade = shade * (1 - LIT * slope * light[1])  # a rise across tilts the surface away from +across
    return Surface(cover, shade, outline)
