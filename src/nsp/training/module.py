"""The Lightning wrapper that trains any neural renderer against the vector engine."""
from __future__ import annotations

import time
from typing import Any, Callable, Optional

import pytorch_lightning as L
import torch
import torch.nn.functional as F
from pytorch_lightning.loggers import TensorBoardLogger
from pytorch_lightning.utilities import grad_norm
from torch import Tensor
from torchmetrics.image import PeakSignalNoiseRatio
from torchvision.utils import make_grid

from nsp.renderers import build

PREVIEW = 8  # validation strokes shown in the TensorBoard image grid
GRID = "val/rows_true_fg_pred_fg_true_alpha_pred_alpha"  # the grid's tag names its rows, top to bottom


class RendererModule(L.LightningModule):
    """L2 on foreground and alpha; accuracy = mean of PSNR(foreground) and PSNR(alpha) (the paper's),
    on the validation strokes during training and on the test strokes once at the end.

    Args:
        renderer: the ``renderer`` config node as a plain dict (``_target_``, ``size``, ``channel_mult``, …);
            saved in the checkpoint with ``brush`` so :func:`nsp.renderers.checkpoint.load_renderer` rebuilds it.
        brush: brush name.
        optimizer: ``params -> Optimizer`` (a Hydra ``_partial_``).
        scheduler: ``optimizer -> LRScheduler``, or None for a constant rate.
        scheduler_interval: ``"epoch"`` or ``"step"``.
    """

    def __init__(self, renderer: dict[str, Any], brush: str,
                 optimizer: Callable[..., torch.optim.Optimizer] = torch.optim.Adam,
                 scheduler: Optional[Callable[..., Any]] = None, scheduler_interval: str = "epoch"):
        super().__init__()
        if scheduler_interval not in ("epoch", "step"):
            raise ValueError(f"model.scheduler_interval must be 'epoch' or 'step', got '{scheduler_interval}'")
        self.save_hyperparameters("renderer", "brush")
        self.renderer = build(renderer, brush)
        self.optimizer, self.scheduler, self.scheduler_interval = optimizer, scheduler, scheduler_interval
        self.psnr_fg, self.psnr_alpha = PeakSignalNoiseRatio(data_range=1.0), PeakSignalNoiseRatio(data_range=1.0)
        self.last_batch: float | None = None  # when the last training batch began (train/strokes_per_s)

    def forward(self, x: Tensor) -> tuple[Tensor, Tensor]:
        """(B, d) -> foreground (B, 3, S, S), alpha (B, 1, S, S)."""
        return self.renderer(x)

    def loss(self, batch: tuple[Tensor, Tensor, Tensor]) -> tuple[Tensor, Tensor, Tensor]:
        """The L2 loss, and the predicted foreground and alpha."""
        x, fg, alpha = batch
        fg_hat, alpha_hat = self(x)
        return F.mse_loss(fg_hat, fg) + F.mse_loss(alpha_hat, alpha), fg_hat, alpha_hat

    def training_step(self, batch, batch_idx: int) -> Tensor:
        loss, _, _ = self.loss(batch)
        self.log("train/loss", loss, prog_bar=True)
        return loss

    def on_train_batch_start(self, batch, batch_idx: int) -> None:
        """Logs ``train/strokes_per_s``, from one batch's start to the next's (rendering the strokes
        included). Lightning's ThroughputMonitor would chart a dozen running counts per stage instead."""
        now = time.perf_counter()
        if self.last_batch is not None:
            self.log("train/strokes_per_s", len(batch[0]) / (now - self.last_batch))
        self.last_batch = now

    def on_before_optimizer_step(self, optimizer) -> None:
        self.log("train/grad_norm", grad_norm(self, norm_type=2)["grad_2.0_norm_total"])  # a spike before a loss one

    def validation_step(self, batch, batch_idx: int) -> None:
        self.score(batch, batch_idx, "val")

    def test_step(self, batch, batch_idx: int) -> None:
        self.score(batch, batch_idx, "test")

    def score(self, batch, batch_idx: int, split: str) -> None:
        """Accumulate PSNR over a fixed set (``split`` is ``val`` or ``test``)."""
        loss, fg_hat, alpha_hat = self.loss(batch)
        _, fg, alpha = batch
        self.psnr_fg.update(fg_hat, fg)
        self.psnr_alpha.update(alpha_hat, alpha)
        self.log(f"{split}/loss", loss, sync_dist=True)
        if batch_idx == 0:
            self.preview = [t[:PREVIEW] for t in (fg, fg_hat, alpha, alpha_hat)]

    def on_validation_epoch_end(self) -> None:
        self.log_scores("val")
        if isinstance(self.logger, TensorBoardLogger) and self.trainer.is_global_zero and not self.trainer.sanity_checking:
            rows = [t.expand(-1, 3, -1, -1) for t in self.preview]
            grid = make_grid(torch.cat(rows).clamp(0, 1), nrow=len(rows[0]), padding=1, pad_value=0.5)
            self.logger.experiment.add_image(GRID, grid, self.global_step)

    def on_test_epoch_end(self) -> None:
        self.log_scores("test")

    def log_scores(self, split: str) -> None:
        """Log ``{split}/psnr_fg``, ``/psnr_alpha`` and their mean ``/psnr``, over every rank's strokes, at the
        number of steps trained (a logged ``step`` is the x Lightning plots them at; its own would put fit's
        validations one step before the test and the image grid)."""
        psnr_fg, psnr_alpha = self.psnr_fg.compute(), self.psnr_alpha.compute()  # torchmetrics syncs ranks
        with torch.inference_mode(False):  # states reset under validate()'s inference mode would break fit's updates
            self.psnr_fg.reset()
            self.psnr_alpha.reset()
        scores = {f"{split}/psnr_fg": psnr_fg, f"{split}/psnr_alpha": psnr_alpha, "step": float(self.global_step)}
        self.log_dict(scores, sync_dist=True)
        self.log(f"{split}/psnr", (psnr_fg + psnr_alpha) / 2, prog_bar=split == "val", sync_dist=True)

    def configure_optimizers(self):
        optimizer = self.optimizer(self.parameters())
        if self.scheduler is None:
            return optimizer
        scheduler = {"scheduler": self.scheduler(optimizer), "interval": self.scheduler_interval}
        return {"optimizer": optimizer, "lr_scheduler": scheduler}
