"""The painter's differentiable renderers behind one interface: ``renderer(x (B, d), size) ->
(foreground (B, 3, size, size), alpha (B, 1, size, size))``, each stroke alone; ``renderer.composite(x,
block, under)``, strokes painted in order over their blocks; ``renderer.gains(x, block, canvas, goal,
weights)``, the error each stroke alone takes from its block; ``renderer.resolution(side)``.

``analytic`` is the vector engine's soft mode: any resolution, nothing to train. ``neural`` is a
network trained by ``python -m nsp.train``, the paper's choice: one fixed output size S.
"""
from __future__ import annotations

import torch
from torch import Tensor, nn

from nsp.brushes import Brush
from nsp.engine import composite, render
from nsp.engine.raster import composite_blocks, paint_gains
from nsp.errors import BadInput
from nsp.painter.settings import RendererConfig
from nsp.renderers.checkpoint import load_renderer


class AnalyticRenderer:
    """The soft vector engine.

    Args:
        softness: edge width in block pixels (None: the brush's own); wider edges reach further but blur the optimum.
        block_size: the largest block side rendered; bigger blocks are optimized downsampled.
        compile: the soft shading, forward and back, by its compiled kernels, one for every block
            size (:class:`nsp.engine.raster.AnySizeShade`), as :func:`nsp.engine.raster.rasterize`'s.
    """

    def __init__(self, brush: Brush, softness: float | None = None, block_size: int = 64,
                 compile: bool | None = False):
        self.brush, self.block_size = brush, block_size
        self.softness = brush.softness if softness is None else softness
        self.compile = compile

    def resolution(self, side: int) -> int:
        """Pixels per side a block of ``side`` canvas pixels is optimized at."""
        return min(side, self.block_size)

    def __call__(self, x: Tensor, size: int) -> tuple[Tensor, Tensor]:
        return render(self.brush, x, size, softness=self.softness, compile=self.compile)

    def composite(self, x: Tensor, block: Tensor, under: Tensor) -> Tensor:
        """Strokes x (N, d), in order, each painted over its ``block`` (N,) of ``under`` (B, 3, s, s):
        (B, 3, s, s), only the tiles each touches shaded and blended."""
        return composite_blocks(self.brush, x, block, under, softness=self.softness, compile=self.compile)

    def gains(self, x: Tensor, block: Tensor, canvas: Tensor, goal: Tensor, weights: Tensor) -> Tensor:
        """How much each stroke x (N, d), painted alone over its ``block`` (N,) of ``canvas`` (B, 3, s, s),
        lowers Σ weights·|canvas − goal| there (weights (B, 1, s, s)): (N,), from the tiles each touches."""
        return paint_gains(self.brush, x, block, canvas, goal, weights, softness=self.softness, compile=self.compile)


class NeuralRenderer:
    """A trained network (paper §3.2) whose S×S output every block is resampled to."""

    def __init__(self, network: nn.Module, size: int):
        self.network = network.eval().requires_grad_(False)  # only the strokes are optimized
        self.size = size

    def resolution(self, side: int) -> int:
        return self.size

    def __call__(self, x: Tensor, size: int) -> tuple[Tensor, Tensor]:
        return self.network(x)

    def composite(self, x: Tensor, block: Tensor, under: Tensor) -> Tensor:
        """As :meth:`AnalyticRenderer.composite`: a block's strokes stacked in order, its empty places transparent."""
        blocks, _, size, _ = under.shape
        fg, alpha = self(x, size)
        index = torch.arange(len(x), device=x.device) - torch.searchsorted(block, block)  # a stroke's place in its block
        depth = int(index.max()) + 1 if len(x) else 0
        stacked = fg.new_zeros(blocks, depth, 3, size, size).index_put((block, index), fg)
        return composite(stacked, alpha.new_zeros(blocks, depth, 1, size, size).index_put((block, index), alpha), under)

    def gains(self, x: Tensor, block: Tensor, canvas: Tensor, goal: Tensor, weights: Tensor) -> Tensor:
        """As :meth:`AnalyticRenderer.gains`, from each stroke's whole image."""
        fg, alpha = self(x, canvas.shape[-1])
        under, aim = canvas.index_select(0, block), goal.index_select(0, block)
        painted = torch.lerp(under, fg, alpha)
        return (((under - aim).abs() - (painted - aim).abs()) * weights.index_select(0, block)).sum((1, 2, 3))


def build_renderer(cfg: RendererConfig, brush: Brush,
                   device: torch.device | str = "cpu") -> AnalyticRenderer | NeuralRenderer:
    """The painter's renderer ``cfg`` names: the analytic one (``compile`` true, false or null: auto,
    as :class:`AnalyticRenderer`'s), or the network of its ``nsp.train`` checkpoint on ``device``
    (:class:`BadInput` if it was trained for another brush)."""
    if cfg.name == "analytic":
        return AnalyticRenderer(brush, cfg.softness, cfg.block_size, cfg.compile)
    network, trained_for, size = load_renderer(cfg.checkpoint)
    if trained_for != brush.name:
        raise BadInput(f"renderer.checkpoint={cfg.checkpoint} renders {trained_for} strokes, not brush={brush.name}; "
                       f"use brush={trained_for} or a checkpoint from `python -m nsp.train brush={brush.name}`")
    return NeuralRenderer(network.to(device), size)
