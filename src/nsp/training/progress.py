"""The training progress bar: the run's steps, not epochs (a run ends on ``trainer.max_steps``)."""
from __future__ import annotations

import math

import pytorch_lightning as L
from pytorch_lightning.callbacks import RichProgressBar
from pytorch_lightning.callbacks.progress.rich_progress import CustomBarColumn, RichProgressBarTheme
from rich.progress import ProgressColumn, Task
from rich.table import Column
from rich.text import Text


class Count(ProgressColumn):
    """``step 120/400``, ``Validation 3/16``: the task's name and how far it is."""

    def __init__(self, style: str):
        super().__init__(Column(no_wrap=True))
        self.style = style

    def render(self, task: Task) -> Text:
        total = "?" if task.total is None or math.isinf(task.total) else int(task.total)
        return Text(f"{task.description} {int(task.completed)}/{total}", style=self.style)


class Clock(ProgressColumn):
    """Elapsed • remaining time as ``h:mm:ss`` (hours past 24 stay hours, so the column keeps its width)."""

    max_refresh = 0.5  # seconds: redrawn twice a second at most, so the digits do not flicker

    def __init__(self, style: str):
        super().__init__(Column(no_wrap=True))
        self.style = style

    def render(self, task: Task) -> Text:
        elapsed = task.finished_time if task.finished else task.elapsed
        return Text(f"{_hms(elapsed)} • {_hms(task.time_remaining)}", style=self.style)


def _hms(seconds: float | None) -> str:
    if seconds is None:
        return "-:--:--"
    minutes, s = divmod(int(seconds), 60)
    return f"{minutes // 60}:{minutes % 60:02d}:{s:02d}"


class StepProgressBar(RichProgressBar):
    """Lightning's rich bar over the whole run, one line that the bar fills to the terminal's width:
    ``step 120/400 ━━━━━━━ 0:00:31 • 0:01:12 train/loss: 0.01234 val/psnr: 21.47``, counting optimizer
    steps out of ``trainer.estimated_stepping_batches`` across epochs and from a resumed checkpoint's step.
    Validation and testing keep Lightning's own lines.
    """

    def __init__(self, **kwargs):
        super().__init__(theme=RichProgressBarTheme(metrics_format=".4g"), **kwargs)

    def configure_columns(self, trainer: L.Trainer) -> list:
        theme = self.theme
        bar = CustomBarColumn(bar_width=None, complete_style=theme.progress_bar, finished_style=theme.progress_bar_finished,
                              pulse_style=theme.progress_bar_pulse, table_column=Column(ratio=1))
        return [Count(theme.batch_progress), bar, Clock(theme.time)]

    def on_train_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        super().on_train_start(trainer, pl_module)
        if self.is_enabled and self.progress is not None:
            self.progress.expand = True  # the bar gets the width the text leaves, so the text never wraps
            self.train_progress_bar_id = self._add_task(trainer.estimated_stepping_batches, "step")
            self._update(self.train_progress_bar_id, trainer.global_step)

    def on_train_epoch_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        """Nothing: the count runs on over epochs (Lightning's bar starts again at each)."""

    def on_train_batch_end(self, trainer: L.Trainer, pl_module: L.LightningModule, outputs, batch, batch_idx: int) -> None:
        self._update(self.train_progress_bar_id, trainer.global_step)
        self._update_metrics(trainer, pl_module)
