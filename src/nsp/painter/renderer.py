"""The painter's differentiable renderers behind one interface: ``renderer(x (B, d), size) ->
(foreground (B, 3, size, size), alpha (B, 1, size, size))``, each stroke alone; ``renderer.composite(x,
shown, under)``, each block's strokes painted in order over it; ``renderer.gains(x, block, canvas, goal,
weights)``, the error each stroke alone takes from its block; ``renderer.resolution(side)``.

``analytic`` is the vector engine's soft mode: any resolution, nothing to train. ``neural`` is a
network trained by ``python -m nsp.train``, the paper's choice: one fixed output size S.
"""
from __future__ import annotations

import torch
from torch import Tensor, nn

from nsp.brushes import Brush
from nsp.engine import composite, render
from nsp.engine.raster import composite_blocks, glazed, paint_gains, render_whole
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
        static: every stroke shaded on its whole block (:func:`~nsp.engine.raster.render_whole`), nothing
            read back from the device; else only the tiles it touches, culled on the host. None: on a GPU.
    """

    def __init__(self, brush: Brush, softness: float | None = None, block_size: int = 64,
                 compile: bool | None = False, static: bool | None = None):
        self.brush, self.block_size = brush, block_size
        self.softness = brush.softness if softness is None else softness
        self.compile, self.static = compile, static

    def resolution(self, side: int) -> int:
        """Pixels per side a block of ``side`` canvas pixels is optimized at."""
        return min(side, self.block_size)

    def __call__(self, x: Tensor, size: int, whole: bool = False) -> tuple[Tensor, Tensor]:
        """Strokes x (B, d) each alone on a size² block; ``whole``: every tile shaded (:func:`render_whole`)."""
        return (render_whole if whole else render)(self.brush, x, size, softness=self.softness, compile=self.compile)

    def composite(self, x: Tensor, shown: Tensor | None, under: Tensor) -> Tensor:
        """Strokes x (B, K, d), each block's in order, painted over its block of ``under`` (B, 3, s, s)
        where ``shown`` (B, K) bool (None: all): (B, 3, s, s), differentiable in x and under."""
        if self.static or (self.static is None and x.device.type != "cpu"):
            return _composite(*self(x.flatten(0, 1), under.shape[-1], whole=True), shown, under, self.brush.glaze)
        shown = torch.ones(x.shape[:2], dtype=torch.bool, device=x.device) if shown is None else shown
        return composite_blocks(self.brush, x[shown], shown.nonzero()[:, 0], under, softness=self.softness,
                                compile=self.compile)  # only the tiles each stroke touches shaded and blended

    def gains(self, x: Tensor, block: Tensor, canvas: Tensor, goal: Tensor, weights: Tensor) -> Tensor:
        """How much each stroke x (N, d), painted alone over its ``block`` (N,) of ``canvas`` (B, 3, s, s),
        lowers Σ weights·|canvas − goal| there (weights (B, 1, s, s)): (N,)."""
        if self.static or (self.static is None and x.device.type != "cpu"):
            return _gains(*self(x, canvas.shape[-1], whole=True), block, canvas, goal, weights, self.brush.glaze)
        return paint_gains(self.brush, x, block, canvas, goal, weights, softness=self.softness, compile=self.compile)


class NeuralRenderer:
    """A trained network (paper §3.2) whose S×S output every block is resampled to."""

    def __init__(self, network: nn.Module, size: int, glaze: float = 0.0):
        """``glaze``: its brush's (:attr:`nsp.brushes.Brush.glaze`), for blending the strokes it renders."""
        self.network = network.eval().requires_grad_(False)  # only the strokes are optimized
        self.size, self.glaze = size, glaze

    def resolution(self, side: int) -> int:
        return self.size

    def __call__(self, x: Tensor, size: int) -> tuple[Tensor, Tensor]:
        return self.network(x)

    def composite(self, x: Tensor, shown: Tensor | None, under: Tensor) -> Tensor:
        """As :meth:`AnalyticRenderer.composite`."""
        return _composite(*self(x.flatten(0, 1), under.shape[-1]), shown, under, self.glaze)

    def gains(self, x: Tensor, block: Tensor, canvas: Tensor, goal: Tensor, weights: Tensor) -> Tensor:
        """As :meth:`AnalyticRenderer.gains`, from each stroke's whole image."""
        return _gains(*self(x, canvas.shape[-1]), block, canvas, goal, weights, self.glaze)


def _composite(fg: Tensor, alpha: Tensor, shown: Tensor | None, under: Tensor, glaze: float) -> Tensor:
    """Fg (B·K, 3, s, s), alpha (B·K, 1, s, s), each block's K in order, over ``under`` (B, 3, s, s), where ``shown``."""
    blocks, _, size, _ = under.shape
    if shown is not None:
        alpha = alpha * shown.reshape(-1, 1, 1, 1)
    return composite(fg.view(blocks, -1, 3, size, size), alpha.view(blocks, -1, 1, size, size), under, glaze)


def _gains(fg: Tensor, alpha: Tensor, block: Tensor, canvas: Tensor, goal: Tensor, weights: Tensor,
           glaze: float) -> Tensor:
    """Σ w·(|canvas − goal| − |painted − goal|) (N,) of strokes fg (N, 3, s, s), alpha (N, 1, s, s) on their ``block``."""
    under, aim = canvas.index_select(0, block), goal.index_select(0, block)
    painted = torch.lerp(under, glazed(under, fg, glaze), alpha)
    return (((under - aim).abs() - (painted - aim).abs()) * weights.index_select(0, block)).sum((1, 2, 3))


def build_renderer(cfg: RendererConfig, brush: Brush,
                   device: torch.device | str = "cpu") -> AnalyticRenderer | NeuralRenderer:
    """The painter's renderer ``cfg`` names: the analytic one (``compile`` true, false or null: auto,
    as :class:`AnalyticRenderer`'s), or the network of its ``nsp.train`` checkpoint on ``device``
    (:class:`BadInput` if it was trained for another brush)."""
    if cfg.name == "analytic":
        return AnalyticRenderer(brush, cfg.softness, cfg.block_size, cfg.compile, cfg.static)
    network, trained_for, size = load_renderer(cfg.checkpoint)
    if trained_for != brush.name:
        raise BadInput(f"renderer.checkpoint={cfg.checkpoint} renders {trained_for} strokes, not brush={brush.name}; "
                       f"use brush={trained_for} or a checkpoint from `python -m nsp.train brush={brush.name}`")
    return NeuralRenderer(network.to(device), size, brush.glaze)
