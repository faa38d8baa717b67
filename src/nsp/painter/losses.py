"""The painter's similarity loss (paper eq. 6): L = β_l1·L1 + β_ot·L_ot, plus extra weighted terms
(style transfer adds β_sty·L_style, paper eq. 7)."""
from __future__ import annotations

from typing import Callable, Mapping

from torch import Tensor

from nsp.painter.transport import transport_loss


class PaintLoss:
    """Weighted loss terms between canvases and their targets.

    Args:
        l1: β_l1, weight of the mean absolute pixel difference.
        ot: β_ot, weight of the transportation loss; 0 skips computing it.
        grid, eps, iters: the transportation loss's grid side, ε and Sinkhorn iterations (their
            defaults: ``nsp.painter.settings.LossConfig``).
        background: RGB in [0, 1] of the blank canvas (what carries no transport mass).
        extra: name -> (weight, loss of the canvas alone), e.g. a style loss.
    """

    def __init__(self, l1: float, ot: float, grid: int, eps: float, iters: int,
                 background: tuple[float, float, float] = (1.0, 1.0, 1.0),
                 extra: Mapping[str, tuple[float, Callable[[Tensor], Tensor]]] | None = None):
        self.l1, self.ot, self.grid, self.eps, self.iters, self.background = l1, ot, grid, eps, iters, background
        self.extra = dict(extra or {})

    @classmethod
    def from_config(cls, loss, background: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> PaintLoss:
        """The loss a ``loss`` config node describes (``nsp.painter.settings.LossConfig``)."""
        return cls(loss.l1, loss.ot, loss.ot_grid, loss.ot_eps, loss.ot_iters, background)

    def __call__(self, canvas: Tensor, target: Tensor) -> dict[str, Tensor]:
        """canvas, target: (B, 3, H, W) in [0, 1] -> scalar terms ``l1``, ``ot`` (if weighted), the
        extra terms, and their weighted sum ``total``; each term a mean over the batch."""
        terms = {"l1": (canvas - target).abs().mean()}
        weights = {"l1": self.l1}
        if self.ot:
            terms["ot"] = transport_loss(canvas, target, self.grid, self.eps, self.iters, self.background)
            weights["ot"] = self.ot
        for name, (weight, loss) in self.extra.items():
            terms[name], weights[name] = loss(canvas), weight
        terms["total"] = sum(weights[name] * value for name, value in terms.items())
        return terms
