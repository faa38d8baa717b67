"""Training: the data, a few steps lowering the loss, checkpoints the painter can load, ``train(cfg)``."""
import json
import subprocess
import sys
from pathlib import Path

import pytorch_lightning as L
import pytest
import torch
import torch.nn.functional as F
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
from tensorboard.plugins.hparams.plugin_data_pb2 import HParamsPluginData

from nsp.brushes import get_brush
from nsp.engine import render
from nsp.renderers.checkpoint import load_renderer
from nsp.training.data import StrokeData
from nsp.training.module import RendererModule
from nsp.training.run import SaveOnInterrupt, train
from nsp.training.data import EpochSampler, RandomStrokes
from nsp.training.schema import register_configs

CONF = Path(__file__).parents[1] / "conf" / "train"
TINY = {"_target_": "nsp.renderers.DualPathway", "size": 32, "channel_mult": 0.125}


def tiny_trainer(**kwargs) -> L.Trainer:
    return L.Trainer(
        accelerator="cpu", logger=False, enable_checkpointing=False, enable_progress_bar=False,
        enable_model_summary=False, num_sanity_val_steps=0, **kwargs,
    )


def test_batches_are_engine_renderings_fresh_each_epoch_and_the_same_whoever_renders_them():
    brush = get_brush("markerpen")
    x, fg, alpha = RandomStrokes(brush, 4, seed=7, size=32)[3]
    expected_fg, expected_alpha = render(brush, x, 32)
    assert torch.equal(fg, expected_fg) and torch.equal(alpha, expected_alpha)

    on_device = StrokeData("markerpen", 32, batch_size=4, epoch_size=12, val_size=4, seed=7, render_on_device=True)
    in_workers = StrokeData("markerpen", 32, batch_size=4, epoch_size=12, val_size=4, seed=7, num_workers=1)
    for data in (on_device, in_workers):
        data.setup("fit")
    device_batches = [on_device.on_after_batch_transfer(b, 0) for b in on_device.train_dataloader()]
    worker_batches = [in_workers.on_after_batch_transfer(b, 0) for b in in_workers.train_dataloader()]
    assert len(device_batches) == 3
    for ours, theirs in zip(device_batches, worker_batches):
        assert all(torch.equal(a, b) for a, b in zip(ours, theirs))

    sampler = EpochSampler(5)
    first = list(sampler)
    sampler.set_epoch(1)
    assert len(first) == 5 and set(first).isdisjoint(sampler)
    ranks = [list(EpochSampler(5, rank, 2)) for rank in (0, 1)]
    assert sorted(ranks[0] + ranks[1]) == first


def test_compiled_rendering_draws_the_same_batches():
    eager = StrokeData("tape", 32, batch_size=8, epoch_size=16, val_size=4, seed=3)
    fused = StrokeData("tape", 32, batch_size=8, epoch_size=16, val_size=4, seed=3, compile=True)
    for data in (eager, fused):
        data.setup("fit")
    for ours, theirs in zip(eager.train_dataloader(), fused.train_dataloader()):
        assert torch.equal(ours[0], theirs[0])
        assert all(torch.allclose(a, b, atol=1e-5) for a, b in zip(ours[1:], theirs[1:]))


def test_validation_and_test_sets_are_fixed_whatever_the_training_seed_and_apart():
    sets = []
    for seed in (0, 1):
        data = StrokeData("tape", 32, batch_size=8, val_size=16, test_size=16, seed=seed)
        data.setup("fit")
        data.setup("test")
        sets.append((data.val_set.tensors[0], data.test_set.tensors[0]))
    assert torch.equal(sets[0][0], sets[1][0]) and torch.equal(sets[0][1], sets[1][1])
    assert not torch.isclose(sets[0][0][:, None], sets[0][1][None]).all(-1).any()  # no test stroke is a validation stroke


def test_a_few_steps_lower_the_loss_and_the_checkpoint_gives_the_same_renderer(tmp_path):
    L.seed_everything(0)
    data = StrokeData("watercolor", 32, batch_size=16, epoch_size=16 * 25, val_size=64)
    model = RendererModule(TINY, "watercolor", optimizer=lambda p: torch.optim.Adam(p, 3e-3))
    trainer = tiny_trainer(max_steps=25)
    before = trainer.validate(model, datamodule=data, verbose=False)[0]
    trainer.fit(model, datamodule=data)
    after = trainer.validate(model, datamodule=data, verbose=False)[0]
    assert after["val/loss"] < 0.9 * before["val/loss"]
    assert after["val/psnr"] == pytest.approx((after["val/psnr_fg"] + after["val/psnr_alpha"]) / 2)

    trainer.save_checkpoint(tmp_path / "model.ckpt")
    renderer, brush, size = load_renderer(tmp_path / "model.ckpt")
    assert (brush, size, renderer.training) == ("watercolor", 32, False)
    x = get_brush("watercolor").sample(4)
    with torch.no_grad():
        for loaded, trained in zip(renderer(x), model.eval()(x)):
            assert torch.equal(loaded, trained)


def test_interrupt_keeps_a_resumable_checkpoint(tmp_path):
    class CtrlC(L.Callback):
        def on_train_batch_end(self, trainer, *args):
            if trainer.global_step == 2:
                raise KeyboardInterrupt

    data = StrokeData("tape", 32, batch_size=4, epoch_size=40, val_size=8)
    trainer = tiny_trainer(max_steps=10, callbacks=[SaveOnInterrupt(tmp_path / "last.ckpt"), CtrlC()])
    with pytest.raises(SystemExit):
        trainer.fit(RendererModule(TINY, "tape"), datamodule=data)
    assert torch.load(tmp_path / "last.ckpt", weights_only=True)["global_step"] == 2


def compose_train(tmp_path: Path, *overrides: str):
    register_configs()
    with initialize_config_dir(str(CONF), version_base="1.3"):
        cfg = compose("train", overrides=[
            "model.channel_mult=0.125", "data.batch_size=8", "data.epoch_size=32", "data.val_size=16", "data.test_size=16",
            "trainer.max_steps=8", "trainer.log_every_n_steps=2", "trainer.num_sanity_val_steps=0", "trainer.enable_progress_bar=false",
            f"output_dir={tmp_path}", *overrides,
        ], return_hydra_config=True)
    HydraConfig.instance().set_config(cfg)
    return cfg


def hparams(events: EventAccumulator) -> tuple[dict, list[str]]:
    """The HPARAMS entry of a run's events: its settings, in the order the tab lists them, and the tags of its metrics."""
    content = {tag: HParamsPluginData.FromString(data) for tag, data in events.PluginTagToContent("hparams").items()}
    settings = content["_hparams_/session_start_info"].session_start_info.hparams
    experiment = content["_hparams_/experiment"].experiment
    order = [info.name for info in experiment.hparam_infos]  # as the HPARAMS tab lists (and ticks) them
    return ({key: settings[key].string_value or settings[key].number_value for key in order},
            [m.name.tag for m in experiment.metric_infos])


def test_train_writes_metrics_checkpoints_and_tensorboard(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("COLUMNS", "80")
    metrics = train(compose_train(tmp_path, "renderer=dcgan", "brush=oilpaint", "trainer.max_steps=10",
                                  "trainer.enable_progress_bar=true"))
    assert json.loads((tmp_path / "metrics.json").read_text()) == metrics
    assert {"val/psnr", "val/psnr_fg", "val/psnr_alpha", "test/psnr", "test/psnr_fg", "test/psnr_alpha", "seconds"} <= metrics.keys()
    assert metrics["test/psnr"] != metrics["val/psnr"]  # scored on other strokes
    assert (metrics["steps"], metrics["renderer"], metrics["brush"], metrics["status"]) == (10, "dcgan", "oilpaint", "completed")
    assert (metrics["lr"], metrics["seed"]) == (3e-3, 0)
    assert {p.name for p in (tmp_path / "checkpoints").iterdir()} == {"best.ckpt", "last.ckpt"}
    assert load_renderer(tmp_path / "checkpoints" / "best.ckpt")[1:] == ("oilpaint", 32)

    # The progress bar counts steps of the run, on one line of 80 columns.
    bar = [line for line in capsys.readouterr().out.splitlines() if line.startswith("step ")]
    assert len(bar) == 1 and bar[0].startswith("step 10/10 ") and len(bar[0]) <= 80
    assert "train/loss: " in bar[0] and "val/psnr: " in bar[0]

    # TensorBoard: one event file; charts grouped train/ val/ test/ lr/, no epoch; validations every epoch
    # (4 steps) and, once, at the last step, mid-epoch; the final scores in HPARAMS with the run's settings.
    assert len(list(tmp_path.glob("events.out.tfevents.*"))) == 1
    events = EventAccumulator(str(tmp_path), size_guidance={"scalars": 0, "images": 0}).Reload()
    assert set(events.Tags()["scalars"]) == {"train/loss", "train/grad_norm", "train/strokes_per_s", "lr/Adam", "val/loss", "val/psnr", "val/psnr_fg", "val/psnr_alpha",
                                             "test/loss", "test/psnr", "test/psnr_fg", "test/psnr_alpha"}
    assert [e.step for e in events.Scalars("val/psnr")] == [4, 8, 10]
    assert events.Scalars("val/psnr")[-1].value == pytest.approx(metrics["val/psnr"], abs=1e-3)
    assert [e.step for e in events.Scalars("test/psnr")] == [10]
    assert events.Tags()["images"] == ["val/rows_true_fg_pred_fg_true_alpha_pred_alpha"]
    assert all(e.value > 0 for e in events.Scalars("train/strokes_per_s") + events.Scalars("train/grad_norm"))
    assert "max_steps: 10" in events.Tensors("config/text_summary")[0].tensor_proto.string_val[0].decode()  # TEXT: the config
    assert [e.step for e in events.Images("val/rows_true_fg_pred_fg_true_alpha_pred_alpha")] == [4, 8, 10]
    settings, final = hparams(events)
    assert list(settings.items())[:5] == [("renderer", "dcgan"), ("brush", "oilpaint"), ("seed", 0), ("lr", 3e-3), ("size", 32)]
    assert settings == {"renderer": "dcgan", "brush": "oilpaint", "size": 32, "channel_mult": 0.125, "batch_size": 8,
                        "epoch_size": 32, "max_steps": 10, "lr": 3e-3, "lr_schedule": "CosineAnnealingLR", "seed": 0}
    assert final == ["val/psnr", "val/psnr_fg", "val/psnr_alpha", "test/psnr", "test/psnr_fg", "test/psnr_alpha"]

    # Resuming continues from the saved step; resumed at its last step, a run trains nothing and scores the same.
    last = tmp_path / "checkpoints" / "last.ckpt"
    resumed = train(compose_train(tmp_path / "resumed", "renderer=dcgan", "brush=oilpaint", "trainer.max_steps=12",
                                  f"ckpt_path={last}"))
    assert resumed["steps"] == 12
    again = train(compose_train(tmp_path / "again", "renderer=dcgan", "brush=oilpaint", "trainer.max_steps=10",
                                f"ckpt_path={last}"))
    assert (again["steps"], again["val/psnr"], again["test/psnr"]) == (10, metrics["val/psnr"], metrics["test/psnr"])


def test_load_renderer_refuses_other_files(tmp_path):
    (tmp_path / "notes.txt").write_text("not a checkpoint")
    torch.save({"state_dict": {}}, tmp_path / "other.ckpt")
    for path in (tmp_path / "notes.txt", tmp_path / "other.ckpt"):
        with pytest.raises(ValueError, match="is not an nsp renderer checkpoint"):
            load_renderer(path)


def test_ddp_on_cpu_splits_the_strokes_syncs_the_metrics_and_writes_one_run(tmp_path):
    """``trainer=ddp trainer.accelerator=cpu trainer.devices=2``: two processes over gloo."""
    done = subprocess.run([sys.executable, str(Path(__file__).parent / "ddp_job.py"), str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    ranks = [json.loads((tmp_path / f"rank{r}.json").read_text()) for r in (0, 1)]
    assert [(r["backend"], r["world_size"]) for r in ranks] == [("gloo", 2)] * 2
    assert ranks[0]["first_stroke"] != ranks[1]["first_stroke"]  # each rank trains on its own strokes
    assert ranks[0]["val_share"] == ranks[1]["val_share"] == 16  # and scores half the validation strokes,
    assert ranks[0]["local_mse"] != ranks[1]["local_mse"]  # with its own error on them,
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert ranks[0]["val/psnr"] == ranks[1]["val/psnr"] == pytest.approx(metrics["val/psnr"], abs=1e-3)  # yet all agree
    # ... on the PSNR of the whole set, as one process scores the saved renderer (not a mean of two halves' PSNRs).
    renderer, _, _ = load_renderer(tmp_path / "checkpoints" / "last.ckpt")
    data = StrokeData("watercolor", 32, val_size=32)
    data.setup("validate")
    x, fg, alpha = data.val_set.tensors
    with torch.no_grad():
        fg_hat, alpha_hat = renderer(x)
    psnr = [-10 * torch.log10(F.mse_loss(a, b)) for a, b in ((fg_hat, fg), (alpha_hat, alpha))]
    assert float(sum(psnr) / 2) == pytest.approx(metrics["val/psnr"], abs=2e-3)
    assert (metrics["steps"], metrics["status"]) == (2, "completed") and "test/psnr" in metrics
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.suffix in (".json", ".ckpt")) == [
        "checkpoints/best.ckpt", "checkpoints/last.ckpt", "metrics.json", "rank0.json", "rank1.json"]


def test_training_that_diverges_stops_at_that_step_keeping_the_last_finite_checkpoint(tmp_path):
    from nsp.errors import RunFailed

    class Diverge(L.Callback):  # what a learning rate far too high does, at step 6 (a checkpoint was saved at 4)
        def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx):
            if trainer.global_step == 6:
                with torch.no_grad():
                    next(pl_module.parameters()).fill_(float("nan"))

    cfg = compose_train(tmp_path, "renderer=dcgan", "brush=tape", "data.num_workers=0")
    with pytest.raises(RunFailed, match=r"training diverged at step 6: .*the last finite checkpoint: .*last\.ckpt"):
        train(cfg, callbacks=[Diverge()])
    metrics = json.loads((tmp_path / "metrics.json").read_text(), parse_constant=lambda name: pytest.fail(name))
    assert metrics["status"] == "failed" and metrics["steps"] == 6
    state = torch.load(tmp_path / "checkpoints" / "last.ckpt", weights_only=True)
    assert state["global_step"] == 4 and all(torch.isfinite(v).all() for v in state["state_dict"].values())


def test_a_diverging_training_command_is_one_line_and_exit_1(tmp_path):
    result = subprocess.run([sys.executable, "-m", "nsp.train", "renderer=dual", "brush=tape", "trainer.max_steps=8",
                             "data.epoch_size=256", "model.optimizer.lr=1e6", "data.num_workers=0",
                             f"hydra.run.dir={tmp_path}"], capture_output=True, text=True)
    assert result.returncode == 1
    assert result.stderr.strip().splitlines()[-1].startswith("error: training diverged at step ")
    assert json.loads((tmp_path / "metrics.json").read_text())["status"] == "failed"


def test_mixed_precision_trains_from_the_command_line_and_keeps_float32_weights(tmp_path):
    """``trainer.precision=bf16-mixed`` (docs/training.md), as a user types it: the forward in bfloat16,
    the weights a painter loads in float32 and finite."""
    result = subprocess.run([sys.executable, "-m", "nsp.train", "renderer=dcgan", "brush=tape", "trainer.max_steps=8",
                             "data.epoch_size=256", "data.num_workers=0", "trainer.precision=bf16-mixed",
                             f"hydra.run.dir={tmp_path}"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["status"] == "completed" and metrics["steps"] == 8
    state = torch.load(tmp_path / "checkpoints" / "last.ckpt", weights_only=True)["state_dict"]
    weights = [v for v in state.values() if v.is_floating_point()]
    assert weights and all(v.dtype == torch.float32 and torch.isfinite(v).all() for v in weights)


def test_a_checkpoint_save_cut_short_leaves_the_previous_one_whole(tmp_path, monkeypatch):
    import errno

    from nsp.training.run import AtomicCheckpointIO

    writer, path = AtomicCheckpointIO(), tmp_path / "checkpoints" / "last.ckpt"
    writer.save_checkpoint({"step": 1, "weights": torch.ones(3)}, path)

    write_bytes = Path.write_bytes

    def full_disk(self, data):  # half a file written, then the disk is full (or the process is killed)
        write_bytes(self, bytes(data)[: len(data) // 2])
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Path, "write_bytes", full_disk)
    with pytest.raises(OSError):
        writer.save_checkpoint({"step": 2, "weights": torch.zeros(3)}, path)
    monkeypatch.undo()
    assert torch.load(path, weights_only=True)["step"] == 1  # the previous checkpoint, whole
    assert [p.name for p in path.parent.iterdir()] == ["last.ckpt"]  # no partial file left beside it


def test_a_full_disk_stops_training_with_one_line_and_the_checkpoints_whole(tmp_path, monkeypatch):
    import errno

    from nsp.errors import RunFailed
    from nsp.training.run import AtomicCheckpointIO

    save = AtomicCheckpointIO.save_checkpoint

    def until_step_4(self, checkpoint, path, storage_options=None):
        if checkpoint["global_step"] > 4:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        save(self, checkpoint, path)

    monkeypatch.setattr(AtomicCheckpointIO, "save_checkpoint", until_step_4)
    cfg = compose_train(tmp_path, "renderer=dcgan", "brush=tape", "data.num_workers=0")
    with pytest.raises(RunFailed, match=r"training stopped at step \d: cannot write .*\.ckpt \(No space left on device\)"):
        train(cfg)
    assert torch.load(tmp_path / "checkpoints" / "last.ckpt", weights_only=True)["global_step"] == 4
    assert json.loads((tmp_path / "metrics.json").read_text())["status"] == "failed"
