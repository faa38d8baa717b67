"""A training run (paper §3.2, §4): ``train(cfg)`` fits the renderer a composed ``nsp.train`` config
describes (``output_dir`` set; no Hydra needed) and writes checkpoints, TensorBoard events and
``metrics.json``."""
from __future__ import annotations

import io
import logging
import math
import signal
import time
import warnings
import zipfile
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Iterator, Sequence

import pytorch_lightning as L
import torch
from hydra.utils import instantiate
from lightning_fabric.plugins import TorchCheckpointIO
from pytorch_lightning.callbacks import Callback, LearningRateMonitor, ModelCheckpoint
from pytorch_lightning.utilities.exceptions import SIGTERMException
from omegaconf import DictConfig, OmegaConf

from nsp.errors import BadInput, RunFailed
from nsp.files import atomic_path, write_json
from nsp.renderers.checkpoint import check_checkpoint
from nsp.signals import shielded
from nsp.training.data import StrokeData
from nsp.training.logger import RunLogger
from nsp.training.module import RendererModule
from nsp.training.progress import StepProgressBar
from nsp.training.checks import check

METRICS = ("val/psnr", "val/psnr_fg", "val/psnr_alpha", "test/psnr", "test/psnr_fg", "test/psnr_alpha")

log = logging.getLogger(__name__)


class SaveOnInterrupt(Callback):
    """Saves a resumable checkpoint when training is interrupted (Ctrl-C, SIGTERM). Lightning's
    ``OnExceptionCheckpoint`` does too, but also turns every ``fit`` into a resume from the last one."""

    def __init__(self, path: Path):
        self.path = path

    def on_exception(self, trainer: L.Trainer, pl_module: L.LightningModule, exception: BaseException) -> None:
        if isinstance(exception, (KeyboardInterrupt, SIGTERMException)):
            epochs, loop = trainer.fit_loop.epoch_progress.current, trainer.fit_loop.epoch_loop
            if epochs.ready == epochs.completed:  # stopped between epochs (Lightning's SIGTERM check at an epoch's end)
                # The next epoch's batch counts are zero, as its start would make them: a resume would skip it else.
                for progress in (loop.batch_progress, loop.scheduler_progress, loop.automatic_optimization.optim_progress):
                    progress.reset_on_run()
            trainer.save_checkpoint(self.path)


class StopBetweenSteps(Callback):
    """Ctrl-C and SIGTERM while fitting stop training at the end of the step (and validation pass)
    under way, so the checkpoint :class:`SaveOnInterrupt` writes resumes exactly; a second stops at once."""

    def __init__(self):
        self.asked = False

    @contextmanager
    def listening(self) -> Iterator[None]:
        """Hear the signals while the block (``trainer.fit``) runs; one a shell set ignored stays ignored."""
        signals = [sig for sig in (signal.SIGINT, signal.SIGTERM) if signal.getsignal(sig) is not signal.SIG_IGN]
        previous = {sig: signal.signal(sig, self._ask) for sig in signals}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)

    def _ask(self, signum: int, frame) -> None:
        if self.asked:
            raise KeyboardInterrupt
        self.asked = True

    def on_train_batch_start(self, trainer: L.Trainer, *args) -> None:
        if self.asked:  # the step before, and the validation pass that ended its epoch, are done
            raise KeyboardInterrupt


class AtomicCheckpointIO(TorchCheckpointIO):
    """Writes a checkpoint beside its target and renames it into place, so a crash, a kill or a full
    disk mid-save leaves the previous file whole (Lightning's copies from the system's temp dir)."""

    def save_checkpoint(self, checkpoint: dict, path, storage_options=None) -> None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        data = io.BytesIO()  # torch's own writer reports a full disk as a RuntimeError with no errno
        torch.save(checkpoint, data)
        with atomic_path(path) as temporary:
            temporary.write_bytes(data.getbuffer())


class StopOnNonFinite(Callback):
    """Stops training at the first step whose loss or updated weights are not finite, before any
    checkpoint holds them: :class:`~nsp.errors.RunFailed` names the step."""

    def on_train_batch_end(self, trainer: L.Trainer, pl_module: L.LightningModule, outputs, batch, batch_idx: int) -> None:
        loss = outputs["loss"] if isinstance(outputs, dict) else outputs
        if not torch.isfinite(loss).all() or not all(torch.isfinite(p).all() for p in pl_module.parameters()):
            raise RunFailed(f"training diverged at step {trainer.global_step}: the loss or the weights are not finite "
                            f"(loss {float(loss):g}); try a lower model.optimizer.lr")


class ValidateLastStep(Callback):
    """Makes the step that reaches ``trainer.max_steps`` a validation step (Lightning validates at an
    epoch's end, or when asked to stop mid-epoch), so the final scores and the last point of every
    ``val/`` curve are one pass. ``step``: the global step of the last validation in ``fit`` (-1 before any)."""

    def __init__(self):
        self.step = -1

    def on_train_batch_end(self, trainer: L.Trainer, *args) -> None:
        if trainer.global_step == trainer.max_steps:
            trainer.should_stop = True

    def on_validation_end(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        if not trainer.sanity_checking:
            self.step = trainer.global_step


def train(cfg: DictConfig, callbacks: Sequence[Callback] = ()) -> dict:
    """Train the renderer ``cfg`` describes, with ``callbacks`` beside the trainer's own; write
    checkpoints, TensorBoard events and ``metrics.json``, and return its metrics. The final model is
    scored on the validation strokes (by fit's last validation), then once on the test strokes.
    Raises ``ValueError`` for a value it cannot train with, before any work; ``KeyboardInterrupt``
    once an interrupted run (Ctrl-C, SIGTERM) has saved ``checkpoints/last.ckpt`` and its metrics."""
    check(cfg)
    if cfg.ckpt_path is not None:
        check_checkpoint(cfg.ckpt_path, OmegaConf.to_container(cfg.renderer, resolve=True, enum_to_str=True), cfg.brush.name)
        check_whole(cfg.ckpt_path)
    with quiet_lightning():
        return _fit(cfg, callbacks)


def check_whole(path: str | Path) -> None:
    """Raise :class:`~nsp.errors.BadInput` where checkpoint ``path`` is not as saved: a checksum of its
    zip archive's parts fails, which ``torch.load`` does not check (a resume would seem to diverge)."""
    advice = "resume from another checkpoint, or remove it to train from the start"
    try:
        with zipfile.ZipFile(path) as archive:
            damaged = archive.testzip()  # the first part whose bytes fail their checksum
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, RuntimeError) as error:  # zlib's; a part cut short
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise BadInput(f"ckpt_path={path} is corrupt ({reason}); {advice}") from None
    if damaged:
        raise BadInput(f"ckpt_path={path} is corrupt: its part {damaged} is not as it was saved (a checksum differs); {advice}")


def _fit(cfg: DictConfig, callbacks: Sequence[Callback]) -> dict:
    L.seed_everything(cfg.seed, workers=True)
    out = Path(cfg.output_dir)
    rates = cfg.lr_by_renderer.get(f"{cfg.model.size}px", {})
    if rates and cfg.renderer.name not in rates:  # a renderer of one's own in a study: said, not silent
        log.info(f"renderer={cfg.renderer.name} has no rate in lr_by_renderer for {cfg.model.size} px: "
                 f"model.optimizer.lr={cfg.model.optimizer.lr}, the default")
    data = StrokeData(cfg.brush.name, cfg.model.size, seed=cfg.seed, texture=cfg.brush.texture, **cfg.data)
    renderer = OmegaConf.to_container(cfg.renderer, resolve=True, enum_to_str=True)  # checkpoints hold plain types
    model = RendererModule(renderer=renderer, brush=cfg.brush.name, optimizer=instantiate(cfg.model.optimizer),
                           scheduler=instantiate(cfg.model.scheduler),
                           scheduler_interval=str(cfg.model.scheduler_interval))
    logger = RunLogger(out, name="", version="", default_hp_metric=False)  # events in the run dir: the run is named after it
    config = OmegaConf.to_yaml(OmegaConf.masked_copy(cfg, [key for key in cfg if key != "hydra"]), resolve=True)
    logger.experiment.add_text("config", "    " + config.replace("\n", "\n    "))  # TensorBoard's TEXT: the run's config
    checkpoints = out / "checkpoints"
    last_validation, stop = ValidateLastStep(), StopBetweenSteps()
    callbacks = [  # StopOnNonFinite acts before any checkpoint is saved: Lightning calls ModelCheckpoint's hooks last
        *callbacks, stop, StopOnNonFinite(), last_validation,
        # no version counter: a resumed run keeps best.ckpt and last.ckpt current in place
        ModelCheckpoint(checkpoints, filename="best", monitor="val/psnr", mode="max", save_last=True,
                        enable_version_counter=False),
        SaveOnInterrupt(checkpoints / "last.ckpt"), LearningRateMonitor(),
        *([StepProgressBar()] if cfg.trainer.enable_progress_bar else []),
    ]
    # torch's SyncBatchNorm is CUDA-only: on CPU (gloo) each rank keeps its own batch statistics.
    sync_batchnorm = cfg.trainer.sync_batchnorm and cfg.trainer.accelerator != "cpu"
    trainer: L.Trainer = instantiate(cfg.trainer, logger=logger, callbacks=callbacks, default_root_dir=out,
                                     sync_batchnorm=sync_batchnorm, plugins=[AtomicCheckpointIO()])
    start = time.perf_counter()
    try:
        with stop.listening():
            trainer.fit(model, datamodule=data, ckpt_path=cfg.ckpt_path)
    except SystemExit:  # Lightning exits after Ctrl-C or SIGTERM, once last.ckpt is saved
        _finish(trainer, logger, cfg, trainer.callback_metrics, start, "interrupted")
        raise KeyboardInterrupt from None
    except OSError as error:  # a full disk, a dir made read-only: the checkpoints saved so far stay whole
        with suppress(OSError):
            _finish(trainer, logger, cfg, {}, start, "failed")
        raise RunFailed(f"training stopped at step {trainer.global_step}: cannot write "
                        f"{error.filename or cfg.output_dir} ({error.strerror or error})") from None
    except RunFailed as error:
        _finish(trainer, logger, cfg, {}, start, "failed")
        kept = checkpoints / "last.ckpt"
        raise RunFailed(f"{error}; {f'the last finite checkpoint: {kept}' if kept.exists() else 'no checkpoint was saved'}") from None
    try:
        trainer.save_checkpoint(checkpoints / "last.ckpt")  # the final step's, also where max_steps ends mid-epoch
        # The final model's validation scores: fit's last pass, unless that was not of the final model (a run
        # resumed at its last step trains none; trainer.check_val_every_n_epoch may skip the last epoch).
        if last_validation.step == trainer.global_step:
            scores = dict(trainer.callback_metrics)
        else:
            scores = trainer.validate(model, datamodule=data, verbose=False)[0]
        scores |= trainer.test(model, datamodule=data, verbose=False)[0]
    except (SystemExit, KeyboardInterrupt):  # Ctrl-C or SIGTERM while scoring: last.ckpt holds the final step
        with shielded():
            _finish(trainer, logger, cfg, trainer.callback_metrics, start, "interrupted")
        raise KeyboardInterrupt from None
    return _finish(trainer, logger, cfg, scores, start, "completed")


@contextmanager
def quiet_lightning() -> Iterator[None]:
    """Lightning without its INFO lines and four warnings that do not apply (the mid-epoch resume:
    StrokeData's sampler resumes exactly); its other warnings stay."""
    logs = [logging.getLogger(name) for name in ("pytorch_lightning", "lightning_fabric")]
    levels = [log.level for log in logs]
    for log in logs:
        log.setLevel(logging.WARNING)
    try:
        with warnings.catch_warnings():
            for message in ("You're resuming from a checkpoint that ended before the epoch ended",
                            "Checkpoint directory .* exists and is not empty",  # a resume in place
                            r".*isinstance\(treespec, LeafSpec\)", "The number of training batches .* logging interval"):
                warnings.filterwarnings("ignore", message)
            yield
    finally:
        for log, level in zip(logs, levels):
            log.setLevel(level)


def _finish(trainer: L.Trainer, logger: RunLogger, cfg: DictConfig, scores, start: float, status: str) -> dict:
    """Write ``metrics.json`` and the HPARAMS entry (the run's settings and final scores); return the metrics."""
    metrics = {k: round(float(scores[k]), 3) for k in METRICS if k in scores and math.isfinite(float(scores[k]))} | {
        "steps": trainer.global_step, "seconds": round(time.perf_counter() - start, 1),
        "renderer": str(cfg.renderer.name), "brush": cfg.brush.name, "size": cfg.model.size,
        "lr": cfg.model.optimizer.get("lr"), "seed": cfg.seed, "status": status}
    if trainer.is_global_zero:
        logger.log_run(_settings(cfg), [k for k in METRICS if k in metrics])
        write_json(Path(cfg.output_dir) / "metrics.json", metrics)
    return metrics


def _settings(cfg: DictConfig) -> dict:
    """The run's key settings, as the HPARAMS tab lists them: TensorBoard ticks the first five, so
    those are what nsp's studies vary (renderer, brush, seed, rate, size)."""
    scheduler = cfg.model.scheduler
    return {"renderer": str(cfg.renderer.name), "brush": cfg.brush.name, "seed": cfg.seed,
            "lr": cfg.model.optimizer.get("lr"), "size": cfg.model.size, "max_steps": cfg.trainer.max_steps,
            "lr_schedule": scheduler._target_.rsplit(".", 1)[-1] if scheduler else "constant",
            "channel_mult": cfg.model.channel_mult, "batch_size": cfg.data.batch_size,
            "epoch_size": cfg.data.epoch_size}
