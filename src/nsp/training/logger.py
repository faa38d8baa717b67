"""TensorBoard as a training run writes it: one event file, charts grouped ``train/``, ``val/``,
``test/`` and ``lr/``, and one HPARAMS entry."""
from __future__ import annotations

from typing import Any, Mapping, Sequence

from pytorch_lightning.loggers import TensorBoardLogger
from pytorch_lightning.utilities import rank_zero_only
from torch.utils.tensorboard.summary import hparams


class RunLogger(TensorBoardLogger):
    """Lightning's TensorBoard logger with three changes:

    - no ``epoch`` chart (runs are counted in steps), and the learning rate under ``lr/``
      (LearningRateMonitor's ``lr-Adam`` becomes ``lr/Adam``);
    - the event file stays open from ``fit`` to ``test`` (Lightning closes it after each, so every
      stage would start a file of its own); :meth:`log_run` closes it;
    - :meth:`log_run` writes the HPARAMS entry without logging the scores a second time.
    """

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
        writer = self.experiment._get_file_writer()  # as Lightning does: SummaryWriter has no public add_summary
        for summary in hparams(dict(params), dict.fromkeys(metrics, 0.0)):
            writer.add_summary(summary)
        self.experiment.close()
