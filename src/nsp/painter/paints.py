"""Painting with K real paints, as a person with a palette or a machine paints: every stroke exactly one
paint, the strokes laid down paint by paint (a layer a paint, in a fixed order), within a layer in
painting order.

A free painting (any colour, coarse to fine) is turned into a layered one by :func:`lay`: every
stroke's paint, shape and alpha and the paints' colours are optimized together on the whole canvas, the
paints first relaxed (a stroke in several layers at once, annealed to one), then snapped, the strokes
sorted layer by layer and polished. Sorting alone hides the fine strokes of light paints under the
coarse strokes of dark ones; the optimizer moves, shrinks or repaints what hides them
(docs/machine-painting.md; benchmarks/paints.py measures it).
"""
from __future__ import annotations

from typing import Callable, Sequence

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import hex_color, lab_to_rgb, parse_color, rgb_to_lab
from nsp.engine.raster import composite_blocks
from nsp.images import resize
from nsp.painter.optimize import RMSprop, optimize_strokes

LAYER_SIZE = 128  # the long side of the canvas the layered strokes are polished on
LAYER_LR = 3e-3  # RMSprop's rate there (strokes and paints in [0, 1])
CANDIDATES = 3  # the nearest paints a stroke may move between while its paint is relaxed
CLOSE = 100.0  # L*a*b* distance that lowers a candidate's first logit by 1
RELAXED = 0.5  # the share of the steps with relaxed paints
HOTTEST, COLDEST = 0.1, 0.002  # the softmax's temperature at their start and end


class Paints:
    """The paints of a painting, in the order their layers are laid down.

    Args:
        brush: the strokes' brush (which parameters are colours; all of a stroke's take its paint).
        colors: (P, 3) RGB in [0, 1], layer by layer.
    """

    def __init__(self, brush: Brush, colors: Tensor):
        self.brush, self.colors = brush, colors
        self.slots = len(brush.color) // 3  # colours a stroke carries (watercolor's two ends: the same paint)

    def __len__(self) -> int:
        return len(self.colors)

    def hex(self) -> list[str]:
        return [hex_color(color) for color in self.colors.tolist()]

    def of(self, x: Tensor) -> Tensor:
        """The paint (N,) of each stroke x (N, d): the one nearest in L*a*b* to its mean colour."""
        return self.nearest(x, 1)[0][:, 0]

    def nearest(self, x: Tensor, count: int) -> tuple[Tensor, Tensor]:
        """The ``count`` (at most all) paints nearest in L*a*b* to each stroke x (N, d)'s mean colour, nearest
        first, and their distances: (N, count) each."""
        color = x[:, list(self.brush.color)].unflatten(-1, (self.slots, 3)).mean(-2)
        distance = torch.cdist(rgb_to_lab(color), rgb_to_lab(self.colors.to(x)))
        near = distance.topk(min(count, len(self)), -1, largest=False)
        return near.indices, near.values

    def dress(self, x: Tensor, paint: Tensor, colors: Tensor | None = None) -> Tensor:
        """Strokes x (N, d), every colour of each its paint (N,) of ``colors`` (P, 3; default, these)."""
        dressed = x.clone()
        dressed[:, list(self.brush.color)] = (self.colors if colors is None else colors)[paint].repeat(1, self.slots)
        return dressed


def lay(paints: Paints, strokes: Tensor, target: Tensor, background: str, steps: int, tune: bool = True,
        trainable: Sequence[int] | None = None, tick: Callable[[], None] = lambda: None) -> tuple[Tensor, Paints]:
    """The free painting ``strokes`` (N, d) as one of ``paints``, laid layer by layer, by ``steps`` RMSprop
    steps on the whole ``target`` (3, H, W) seen at a :data:`LAYER_SIZE` long side, composited by the soft
    vector engine, in two parts:

    1. relaxed (the first :data:`RELAXED` of the steps): each stroke is in every layer of its
       :data:`CANDIDATES` nearest paints (L*a*b*), its alpha there scaled by a softmax of its logits at
       a temperature annealed from :data:`HOTTEST` to :data:`COLDEST`: a stroke that hides finer ones moves to an
       earlier layer, a paint it shares with them, as its shape and alpha are optimized;
    2. snapped: each stroke takes its heaviest paint, the strokes are sorted by layer (stable: a layer
       keeps its painting order), and the rest of the steps polish every stroke's shape and alpha.

    With ``tune``, the paints' colours (paints the painter chose) are optimized too. Returns the
    strokes in layer order, each exactly its paint, and the paints as they ended (each an 8-bit colour,
    which a file names exactly); ``trainable``: the parameters optimized (None: all); ``tick()`` after
    each step."""
    scene = _Scene(paints, target, background)
    colors = paints.colors.to(strokes).clone().requires_grad_(tune)
    candidates, distance = paints.nearest(strokes, CANDIDATES)  # (N, C) each
    logits = (-distance / CLOSE).requires_grad_(True)  # a stroke's weight in each candidate's layer
    frozen = [] if trainable is None else [i for i in range(paints.brush.d) if i not in set(trainable)]
    relaxed = round(steps * RELAXED)
    x = strokes.clone().requires_grad_(True)
    count, choices = candidates.shape
    pair = candidates.flatten() * count + torch.arange(count, device=x.device).repeat_interleave(choices)
    order = torch.argsort(pair)  # every (layer, stroke) pair, layer by layer, in painting order within one
    stroke, layer = order // choices, candidates.flatten()[order]
    temperature = HOTTEST

    def relaxed_objective() -> tuple[Tensor, dict[str, Tensor]]:
        weight = torch.softmax(logits / temperature, -1).flatten()[order]
        return scene.score(paints.dress(x[stroke], layer, colors), weight)

    def stepped() -> None:
        with torch.no_grad():
            colors.clamp_(0, 1)
        tick()

    optimizer = RMSprop([x, logits, colors] if tune else [x, logits], lr=LAYER_LR, corrected=True)
    for step, _ in enumerate(optimize_strokes(x, optimizer, relaxed, relaxed_objective, frozen)):
        temperature = HOTTEST * (COLDEST / HOTTEST) ** ((step + 1) / relaxed)
        stepped()
    paint = candidates.gather(1, logits.argmax(-1, keepdim=True))[:, 0]
    order = torch.sort(paint, stable=True).indices
    x, paint = x.detach()[order].requires_grad_(True), paint[order]
    optimizer = RMSprop([x, colors] if tune else [x], lr=LAYER_LR, corrected=True)
    for _ in optimize_strokes(x, optimizer, steps - relaxed, lambda: scene.score(paints.dress(x, paint, colors)), frozen):
        stepped()
    laid = Paints(paints.brush, (colors.detach() * 255).round() / 255)
    return laid.dress(x.detach(), paint), laid


class _Scene:
    """The whole target as :func:`lay` scores a layered painting on it: at a :data:`LAYER_SIZE` long side."""

    def __init__(self, paints: Paints, target: Tensor, background: str):
        self.goal = resize(target, LAYER_SIZE)[None]
        color = torch.tensor(parse_color(background), dtype=self.goal.dtype, device=self.goal.device)
        self.under = color[None, :, None, None].expand_as(self.goal)
        self.brush = paints.brush.plain()

    def score(self, x: Tensor, opacity: Tensor | None = None) -> tuple[Tensor, dict[str, Tensor]]:
        """Strokes x (N, d) painted in order over the background in the soft mode, each alpha times its
        ``opacity`` (N,): the canvas and the mean L1 error."""
        canvas = composite_blocks(self.brush, x, torch.zeros(len(x), dtype=torch.long, device=x.device), self.under,
                                  softness=self.brush.softness, opacity=opacity)
        return canvas, {"total": (canvas - self.goal).abs().mean()}


def parse_paints(value: list | tuple) -> Tensor:
    """``paints=[#rrggbb, …]`` (checked: :func:`nsp.config.check_paints`) as (P, 3) RGB."""
    return torch.tensor([parse_color(str(paint)) for paint in value])


def choose_paints(photo: Tensor, count: int, seed: int) -> Tensor:
    """``count`` paints for ``photo`` (3, H, W): k-means (scikit-learn) of its pixels in L*a*b*: (count, 3)."""
    from sklearn.cluster import KMeans

    pixels = rgb_to_lab(photo.reshape(3, -1).T.double().cpu())
    centres = KMeans(count, n_init=4, random_state=seed).fit(pixels.numpy()).cluster_centers_
    return lab_to_rgb(torch.from_numpy(centres)).clamp(0, 1).float()


def in_order(colors: Tensor, order: str) -> Tensor:
    """Paints (P, 3) in the order their layers are laid down: ``light_to_dark`` (a dark stroke covers a
    light one: the painters' and plotters' rule), ``dark_to_light``, or ``listed`` (as given)."""
    if order == "listed":
        return colors
    light = rgb_to_lab(colors)[:, 0]
    return colors[torch.argsort(light, descending=order == "light_to_dark", stable=True)]
