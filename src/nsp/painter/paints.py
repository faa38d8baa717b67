"""Painting with K real paints, as a person with a palette or a machine paints: every stroke exactly one
paint, the strokes laid down paint by paint (a layer a paint, in a fixed order), within a layer in
painting order.

A free painting (any colour, coarse to fine) is turned into a layered one by :func:`lay`: each stroke
takes its nearest paint, the strokes are sorted layer by layer, and then every stroke's shape and the
paints' colours are optimized together on the whole canvas in that order. Sorting alone hides the fine
strokes of light paints under the coarse strokes of dark ones; the polish shrinks and moves what hides
them (docs/machine-painting.md measures it).
"""
from __future__ import annotations

from typing import Callable, Sequence

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import hex_color, lab_to_rgb, parse_color, rgb_to_lab
from nsp.images import long_side, resize
from nsp.painter.optimize import RMSprop, optimize_strokes
from nsp.painter.renderer import AnalyticRenderer

LAYER_SIZE = 128  # the long side of the canvas the layered strokes are polished on
LAYER_LR = 3e-3  # RMSprop's rate there (strokes and paints in [0, 1])


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
        color = x[:, list(self.brush.color)].unflatten(-1, (self.slots, 3)).mean(-2)
        return torch.cdist(rgb_to_lab(color), rgb_to_lab(self.colors.to(x))).argmin(-1)

    def dress(self, x: Tensor, paint: Tensor, colors: Tensor | None = None) -> Tensor:
        """Strokes x (N, d), every colour of each its paint (N,) of ``colors`` (P, 3; default, these)."""
        dressed = x.clone()
        dressed[:, list(self.brush.color)] = (self.colors if colors is None else colors)[paint].repeat(1, self.slots)
        return dressed


def lay(paints: Paints, strokes: Tensor, target: Tensor, background: str, steps: int, tune: bool = True,
        trainable: Sequence[int] | None = None, tick: Callable[[], None] = lambda: None) -> tuple[Tensor, Paints]:
    """The free painting ``strokes`` (N, d) as one of ``paints``, laid layer by layer: each stroke takes
    its nearest paint, the strokes are sorted by layer (stable: a layer keeps its painting order), and
    ``steps`` RMSprop steps optimize every stroke's shape and alpha (and with ``tune``, paints the painter
    chose, their colours) together,
    composited in that order over the whole ``target`` (3, H, W) seen at a :data:`LAYER_SIZE` long side,
    by the soft vector engine. Returns the strokes in layer order, each exactly its paint, and the paints
    as they ended (each an 8-bit colour, which a file names exactly); ``trainable``: the parameters optimized
    (None: all); ``tick()`` after each step."""
    paint = paints.of(strokes)
    order = torch.sort(paint, stable=True).indices
    x, paint = strokes[order].clone().requires_grad_(True), paint[order]
    colors = paints.colors.to(strokes).clone().requires_grad_(tune)
    height, width = long_side(*target.shape[-2:], LAYER_SIZE)
    side = max(height, width)
    goal = torch.nn.functional.pad(resize(target, (height, width)), (0, side - width, 0, side - height))[None]
    weights = torch.zeros(1, 1, side, side, dtype=goal.dtype, device=goal.device)
    weights[..., :height, :width] = 1  # the square block's padding past the canvas does not count
    under = torch.tensor(parse_color(background), dtype=goal.dtype, device=goal.device)[None, :, None, None].expand_as(goal)
    renderer = AnalyticRenderer(paints.brush.plain(), block_size=side)
    optimizer = RMSprop([x, colors] if tune else [x], lr=LAYER_LR, corrected=True)

    def objective() -> tuple[Tensor, dict[str, Tensor]]:
        canvas = renderer.composite(paints.dress(x, paint, colors)[None], None, under)
        return canvas, {"total": ((canvas - goal).abs() * weights).sum() / (3 * weights.sum())}

    frozen = [] if trainable is None else [i for i in range(paints.brush.d) if i not in set(trainable)]
    for _ in optimize_strokes(x, optimizer, steps, objective, frozen):
        with torch.no_grad():
            colors.clamp_(0, 1)
        tick()
    laid = Paints(paints.brush, (colors.detach() * 255).round() / 255)
    return laid.dress(x.detach(), paint), laid


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
