"""TensorBoard as a training run writes it: one event file, charts grouped ``train/``, ``val/``,
``test/`` and ``lr/``, and one HPARAMS entry."""
from __future__ import annotations

from typing import Any, Mapping, Sequence

from pytorch_lightning.loggers import TensorBoardLogger
from pytorch_lightning.utilities import rank_zero_only
from torch.utils.tensorboard.summary import hparams


class RunLogger(TensorBoardLogger):
    """Lightning's TensorBoard logger, with no ``epoch`` chart (runs are counted in steps), the learning
    rate under ``lr/`` (``lr-Adam`` becomes ``lr/Adam``), and one event file from ``fit`` to ``test``
    (Lightning's closes it after each stage): :meth:`log_run` writes the HPARAMS entry, then closes it."""

    @rank_zero_only
    def log_metrics(self, metrics: Mapping[str, float], step: int | None = None) -> None:
        tags = {("lr/" + key.removeprefix("lr-") if key.startswith("lr-") else key): value
                for key, value in metrics.items() if key != "epoch"}
        super().log_metrics(tags, step)

    @rank_zero_only
    def finalize(self, status: str) -> None:
        if self._experiment is not None:
            self._experiment.flush()
        if status == "success":
            self.save()  # hparams.yaml

    @rank_zero_only
    def log_run(self, params: Mapping[str, Any], metrics: Sequence[str]) -> None:
        """The run's HPARAMS entry: its settings ``params`` (name -> number or text) beside ``metrics``,
        tags of scalars already logged (TensorBoard shows each one's last point); then closes the file."""
        # Lightning's log_hyperparams would log each metric again, as a one-point scalar at step 0.
        for summary in hparams(dict(params), dict.fromkeys(metrics, 0.0)):
            self.experiment.file_writer.add_summary(summary)  # the open event file's writer
        self.experiment.close()
