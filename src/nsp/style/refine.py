"""Colour mode's last step: every stroke's colours refined on their own, after the shared map.

Once the shapes are fixed, a painting is linear in its colours: each pixel is a weighted sum of
the colour parameters of the strokes over it and of the canvas colour, the weights set by the
shapes and alphas alone (:func:`color_basis`). So the painting of any colours is one matrix
product, and :func:`refine_colors` can take hundreds of gradient steps on every stroke's colours
for the cost of a few renders.

The steps lower the sliced Wasserstein distance to the style's colours under the same two bounds
as the shared map: the luminance SSIM to the photo stays above a floor, and colours alike in the
painting stay within a bound of each other on average. The shared map keeps alike colours
exactly alike; this step spends what is left of that bound, so strokes of one colour may part a
little where the style's colours vary more than one map can make them, and only in the
directions they vary in (a grey style's: lightness alone).
"""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import hex_color
from nsp.colors import parse_color
from nsp.colors import lab_to_rgb, rgb_to_lab
from nsp.engine import paint_canvas
from nsp.engine.raster import boxed_tiles
from nsp.images import ssim
from nsp.style.losses import sliced_wasserstein
from nsp.style.measures import SAMPLES, alike_pairs, luminance_ssim, parted
from nsp.style.recolor import psd_sqrt

STEPS = 200  # Adam steps on the colours' offsets
RATE = 0.08  # their learning rate, in the style's standard deviations
PIXELS = 2048  # seeded pixels among which the alike pairs are found, and whose colours a step compares
PAIRS = 20000  # the alike pairs a step holds together, drawn afresh
PROJECTIONS = 32  # sliced Wasserstein directions a step draws
JUDGE = 256  # the fixed directions the iterates are compared on, every CHECK steps
CHECK = 20
BACK = 10  # an iterate outside a bound is taken back toward the start, 1/BACK of the way at a time
PENALTY = 10.0  # a bound's excess against the colour distance, relative to the start's
MARGIN = 0.02  # the steps aim this share inside each bound (iterates past one are taken back)
TILE = 8  # the engine's tile (px) when probing
REACH = 2.0  # px around a stroke's box where it may paint: the engine's culling margin (1 px), and 1 to spare


def color_basis(brush: Brush, strokes: Tensor, height: int, width: int) -> Tensor:
    """The weights (H·W, K) with which the painting of ``strokes`` (N, d) is its colours: channel c
    of the canvas is ``basis @ colors(brush, strokes, canvas)[:, c]``, for any colours.

    Probed by painting every colour black but one group of :func:`probes` in each channel; no
    pixel can show two colours of a group, so each pixel's value is its one colour's weight.
    """
    reach = footprints(brush, strokes, height, width)
    per_stroke = len(brush.color) // 3
    groups = probes(reach, per_stroke)
    count = len(strokes) * per_stroke + 1
    basis = torch.zeros(height * width, count)
    for first in range(0, len(groups), 3):
        table = torch.zeros(count, 3)
        for channel, group in enumerate(groups[first:first + 3]):
            table[group, channel] = 1
        x, canvas = with_colors(brush, strokes, table)
        with torch.no_grad():
            image = paint_canvas(brush, x, height, width, canvas=canvas[:, None, None].expand(3, height, width),
                                 tile=TILE).flatten(1)
        for channel, group in enumerate(groups[first:first + 3]):
            for k in group:
                basis[:, k] = image[channel] if k == count - 1 else image[channel] * reach[k // per_stroke]
    return basis


def footprints(brush: Brush, strokes: Tensor, height: int, width: int) -> Tensor:
    """(N, H·W) mask of the pixels each stroke may paint: the engine's tiles that meet its box."""
    tiles = boxed_tiles(brush.extent(strokes.detach(), height, width), height, width, TILE, REACH)
    rows, cols = torch.arange(height)[:, None] // TILE, torch.arange(width)[None, :] // TILE
    return tiles[:, (rows * math.ceil(width / TILE) + cols).flatten()]


def probes(reach: Tensor, per_stroke: int) -> list[list[int]]:
    """The painting's colours (as :func:`colors` lists them, ``per_stroke`` to each of the strokes
    whose pixels ``reach`` (N, P) masks, then the canvas's) in groups of colours that share no
    pixel, greedily in order; the canvas's, under every stroke, alone and last."""
    meet = (reach.float() @ reach.float().T) > 0  # (N, N): strokes that may share a pixel
    groups, members = [], []
    for k in range(len(reach) * per_stroke):
        stroke = k // per_stroke
        for group, taken in zip(groups, members):
            if not (meet[stroke] & taken).any() and not taken[stroke]:
                group.append(k)
                taken[stroke] = True
                break
        else:
            groups.append([k])
            members.append(torch.zeros(len(reach), dtype=torch.bool).index_fill_(0, torch.tensor(stroke), True))
    return groups + [[len(reach) * per_stroke]]


def colors(brush: Brush, strokes: Tensor, canvas: Tensor) -> Tensor:
    """Every RGB colour of the painting (K, 3): each stroke's (``brush.color``, in triples), then
    the ``canvas`` colour (3,)."""
    per_stroke = strokes[:, list(brush.color)].reshape(-1, 3)
    return torch.cat([per_stroke, canvas.to(strokes)[None]])


def with_colors(brush: Brush, strokes: Tensor, table: Tensor) -> tuple[Tensor, Tensor]:
    """``strokes`` (N, d) with the colours of ``table`` (K, 3, as :func:`colors` lists them), and
    the canvas colour (3,); all other parameters bit for bit."""
    x = strokes.detach().clone()
    x[:, list(brush.color)] = table[:-1].reshape(len(x), -1).to(x)
    return x, table[-1]


def refine_colors(brush: Brush, strokes: Tensor, canvas: Tensor, plain: Tensor, photo: Tensor, style: Tensor,
                  floor: float, bound: float, *, spread: Tensor | None = None, steps: int = STEPS,
                  rate: float = RATE, margin: float = MARGIN, tighten: float = 1.0, judge: int = JUDGE, seed: int = 1,
                  basis: Tensor | None = None) -> tuple[Tensor, Tensor]:
    """Every colour of the painting ``strokes`` (N, d) on the canvas colour ``canvas`` (3,) refined
    toward ``style``'s colours (3, h, w): the painting's luminance SSIM to ``photo`` (3, H, W)
    stays ≥ ``floor``, and colours within :data:`~nsp.style.measures.NEAR` of each other in
    ``plain`` (3, H, W, the painting before any recolouring) end up ≤ ``bound`` apart on average.
    Each colour moves by an offset in L*a*b* along ``spread`` (3, 3; offset = spread·u): by default
    the style's own spread of colours (:func:`style_spread`), so strokes part only in the directions
    the style's colours vary in and toward a grey style no stroke takes a hue; the identity frees
    them. ``steps`` Adam steps at ``rate`` aim ``margin`` (a share) inside each bound, with
    penalties that grow linearly to ``tighten`` × :data:`PENALTY` by the last step (more than 1:
    the iterates end nearer the bounds' edge).
    Every :data:`CHECK` steps the iterate is judged, or where it leaves a bound the largest share of
    its offsets (in tenths, back toward the start) within both, its canvas colour as ``#rrggbb``
    holds it (:func:`as_written`). Returns the strokes and canvas
    colour of the best judged, or the ones given if none is nearer the style's colours. Judged on
    every pixel, on ``judge`` directions and coherence's pixels drawn with ``seed``; the steps'
    draws use ``seed`` + 1 (the measures of :mod:`nsp.style.measures` use seed 0: keep it apart,
    but to search on the measures themselves).
    ``basis`` is the painting's :func:`color_basis`, where already built for these shapes.
    """
    generator = torch.Generator().manual_seed(seed + 1)
    height, width = photo.shape[1:]
    basis = color_basis(brush, strokes, height, width) if basis is None else basis
    styles = rgb_to_lab(style.detach().float(), dim=0).flatten(1)
    sampled = styles[:, torch.randperm(styles.shape[1], generator=generator)[:PIXELS]][None, :, :, None]
    styles = styles[None, :, :, None]
    photo_lightness = rgb_to_lab(photo.detach().float(), dim=0)[:1]
    plain_colors = plain.detach().flatten(1).T.float()
    first, second = alike_pairs(plain_colors, PIXELS, generator)
    checked = alike_pairs(plain_colors, SAMPLES, torch.Generator().manual_seed(seed))  # as coherence pairs pixels
    aim_floor, aim_bound = floor + margin * (1 - floor), (1 - margin) * bound

    def paint(table: Tensor) -> Tensor:
        return (basis @ table).T.reshape(3, height, width)

    def distance(image: Tensor, draws: torch.Generator, projections: int, pixels: Tensor | None = None) -> Tensor:
        """To the style's colours: of every pixel, or of ``pixels`` (P,) to as many of the style's."""
        lab = rgb_to_lab(image.flatten(1), dim=0)
        if pixels is None:
            return sliced_wasserstein(lab[None, :, :, None], styles, projections, draws)
        return sliced_wasserstein(lab[None, :, pixels, None], sampled, projections, draws)

    start = colors(brush, strokes, canvas).float()
    scale = max(float(distance(paint(start), torch.Generator().manual_seed(seed), judge)), 1e-6)  # 0: the style's own colours
    spread = style_spread(style) if spread is None else spread.float()
    offsets = torch.zeros_like(start).requires_grad_(True)
    optimizer = torch.optim.Adam([offsets], lr=rate)

    def current(share: float = 1.0) -> Tensor:
        return lab_to_rgb(rgb_to_lab(start) + share * offsets @ spread.T).clamp(0, 1)

    best = (scale, start)
    for step in range(1, steps + 1):
        table = current()
        image = paint(table)
        pick = torch.randint(len(first), (min(len(first), PAIRS),), generator=generator)
        apart = parted(image, first[pick], second[pick]) if len(first) else torch.zeros(())
        structure = ssim(rgb_to_lab(image, dim=0)[:1], photo_lightness)
        compared = torch.randperm(height * width, generator=generator)[:PIXELS]
        penalty = PENALTY * (1 + (tighten - 1) * step / steps)
        loss = distance(image, generator, PROJECTIONS, compared) / scale + penalty * (
            F.relu(aim_floor - structure) + F.relu(apart - aim_bound))
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        if step % CHECK == 0:
            with torch.no_grad():
                for share in range(BACK, 0, -1):  # the nearest share of the offsets within both bounds
                    table = as_written(current(share / BACK))
                    image = paint(table)
                    if luminance_ssim(image, photo) >= floor and not parted(image, *checked) > bound:
                        score = float(distance(image, torch.Generator().manual_seed(seed), judge))
                        if score < best[0]:
                            best = (score, table)
                        break
    return with_colors(brush, strokes, best[1])


def as_written(table: Tensor) -> Tensor:
    """The painting's colours ``table`` (K, 3, as :func:`colors` lists them) with the canvas colour
    on the 8-bit grid of ``#rrggbb``, as the painting's files hold it: a bound judged on the
    painting with the canvas colour unrounded can fail on the painting as written."""
    return torch.cat([table[:-1], torch.tensor([parse_color(hex_color(table[-1]))]).to(table)])


def style_spread(style: Tensor) -> Tensor:
    """The directions and extents in which the colours of ``style`` (3, h, w) vary, in L*a*b* / 100
    (3, 3): Σ½, Σ their covariance."""
    lab = rgb_to_lab(style.detach().float(), dim=0).flatten(1).double()
    return psd_sqrt(torch.cov(lab) + 1e-8 * torch.eye(3, dtype=torch.float64)).float()
