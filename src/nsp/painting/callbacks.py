"""What the painter reports while it works: TensorBoard curves and canvases, a progress bar."""
from __future__ import annotations

import io
import time
from typing import Mapping

from PIL import Image
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from tensorboard.compat.proto.summary_pb2 import Summary
import torch
from torch import Tensor
from torch.utils.tensorboard import SummaryWriter
from torch.utils.tensorboard.summary import hparams

from nsp.images import psnr, resize
from nsp.io.export import to_uint8
from nsp.painter.painter import Callback, Painter


class TensorBoard(Callback):
    """A painting's TensorBoard, on one step axis, the optimizer's steps over all levels: ``loss/<term>``
    per step (the paper's Fig. 7 curves; ``loss/total`` only beside two terms or more); per level,
    ``level/psnr`` of the canvas so far against ``target`` (3, H, W) in [0, 1], and that canvas;
    ``target`` once; and the run's settings beside its final scores in HPARAMS (:meth:`log_run`)."""

    def __init__(self, writer: SummaryWriter, target: Tensor):
        self.writer, self.target, self.step = writer, target, 0
        self.losses: list[tuple[int, dict[str, Tensor]]] = []  # the steps' not yet written
        self._picture("target", target, 0)

    def on_step(self, painter: Painter, step: int, losses: dict[str, Tensor]) -> None:
        self.losses.append((step, losses))  # read and written a level at a time: one wait for the device, not one a step

    def on_level(self, painter: Painter, level: int, canvas: Tensor) -> None:
        self.step = painter.step
        at_target = resize(canvas, tuple(self.target.shape[-2:]))  # a finer last level's canvas too
        self.writer.add_scalar("level/psnr", psnr(at_target, self.target).item(), self.step)
        self._picture("canvas", at_target, self.step)  # final.png has the detail
        self.flush()

    def flush(self) -> None:
        """Write the steps' losses held back, and everything to disk (an interrupted painting too)."""
        logged = [(f"loss/{name}", value, step) for step, losses in self.losses for name, value in losses.items()
                  if name != "total" or len(losses) > 2]
        values = torch.stack([value for _, value, _ in logged]).tolist() if logged else []
        for (tag, _, step), value in zip(logged, values):
            self.writer.add_scalar(tag, value, step)
        self.losses = []
        self.writer.flush()

    def _picture(self, tag: str, image: Tensor, step: int) -> None:
        """``add_image`` of (3, H, W) in [0, 1] as a JPEG (quality 90): add_image's PNG costs the painter
        5× the time (its compression, and the writer's pure-Python checksum of its bytes)."""
        pixels = to_uint8(image)  # (H, W, 3)
        encoded = io.BytesIO()
        Image.fromarray(pixels).save(encoded, format="JPEG", quality=90)
        picture = Summary.Image(height=pixels.shape[0], width=pixels.shape[1], colorspace=3,
                                encoded_image_string=encoded.getvalue())
        self.writer.file_writer.add_summary(Summary(value=[Summary.Value(tag=tag, image=picture)]), step)

    def log_run(self, settings: Mapping[str, str | int | float], scores: Mapping[str, float]) -> None:
        """``final/<score>`` at the last step and the HPARAMS entry: ``settings`` beside those scores."""
        for name, value in scores.items():
            self.writer.add_scalar(f"final/{name}", value, self.step)
        # SummaryWriter.add_hparams would write them into a run dir of their own, and log each score again
        for summary in hparams(dict(settings), {f"final/{name}": 0.0 for name in scores}):
            self.writer.file_writer.add_summary(summary)
        self.writer.flush()


class ProgressBar(Callback):
    """A rich progress bar over the strokes (or other ``unit``), with the level and the last L1 of the one before;
    :attr:`seconds`, once its ``with`` block is done, the time the block took."""

    def __init__(self, total: int, enabled: bool = True, unit: str = "strokes"):
        self.progress = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn(unit),
                                 TimeElapsedColumn(), TimeRemainingColumn(), disable=not enabled)
        self.task = self.progress.add_task("painting", total=total)
        self.l1: Tensor | float = float("nan")

    def __enter__(self) -> "ProgressBar":
        self.progress.start()
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        self.progress.stop()
        self.seconds = time.perf_counter() - self.start  # the whole work: steps after the last stroke too

    def advance(self, count: int, description: str) -> None:
        self.progress.update(self.task, advance=count, description=description)

    def on_strokes(self, painter: Painter, added: int) -> None:
        self.progress.advance(self.task, added)

    def on_step(self, painter: Painter, step: int, losses: dict[str, Tensor]) -> None:
        self.l1 = losses["l1"]  # shown once its level is done: a read a step would wait for the device a step

    def on_level(self, painter: Painter, level: int, canvas: Tensor) -> None:
        self.progress.update(self.task, description=f"level {level + 2} · l1 {float(self.l1):.3f}")
