"""What the painter reports while it works: TensorBoard curves and canvases, a progress bar."""
from __future__ import annotations

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from torch import Tensor
from torch.utils.tensorboard import SummaryWriter

from nsp.painter.painter import Callback, Painter


class TensorBoard(Callback):
    """``loss/l1``, ``loss/ot``, ``loss/total`` per step (the paper's Fig. 7 curves), the canvas per level."""

    def __init__(self, writer: SummaryWriter):
        self.writer = writer

    def on_step(self, painter: Painter, step: int, losses: dict[str, float]) -> None:
        for name, value in losses.items():
            self.writer.add_scalar(f"loss/{name}", value, step)

    def on_level(self, painter: Painter, level: int, canvas: Tensor) -> None:
        self.writer.add_image("canvas", canvas.clamp(0, 1), level + 1)
        self.writer.flush()


class ProgressBar(Callback):
    """A rich progress bar over the strokes (or other ``unit``), with the level and the latest L1."""

    def __init__(self, total: int, enabled: bool = True, unit: str = "strokes"):
        self.progress = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn(unit),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            disable=not enabled,
        )
        self.task = self.progress.add_task("painting", total=total)
        self.level = 1

    def __enter__(self) -> "ProgressBar":
        self.progress.start()
        return self

    def __exit__(self, *exc) -> None:
        self.progress.stop()

    def advance(self, count: int, description: str) -> None:
        self.progress.update(self.task, advance=count, description=description)

    def on_strokes(self, painter: Painter, added: int) -> None:
        self.progress.advance(self.task, added)

    def on_step(self, painter: Painter, step: int, losses: dict[str, float]) -> None:
        self.progress.update(self.task, description=f"level {self.level} · l1 {losses['l1']:.3f}")

    def on_level(self, painter: Painter, level: int, canvas: Tensor) -> None:
        self.level = level + 2
