"""Trains two steps of the real training config with Lightning's DDP on CPU: 2 processes, gloo.

Run by ``test_training.py::test_ddp_on_cpu_...`` as ``python tests/ddp_job.py OUT``; Lightning starts
rank 1 by running this script again. Each rank writes ``OUT/rank<r>.json``: the strokes of its first
training batch, its share of the validation strokes and its own foreground MSE on them, the backend
and the synced ``val/psnr`` it saw.
"""
import json
import sys
from pathlib import Path

import pytorch_lightning as L
import torch.distributed as dist
from hydra import compose, initialize_config_dir

from nsp.training.run import train
from nsp.training.schema import register_configs

CONF = Path(__file__).parents[1] / "conf" / "train"


class Record(L.Callback):
    def __init__(self, out: Path):
        self.out, self.first = out, None

    def on_train_batch_start(self, trainer, module, batch, batch_idx):
        if self.first is None:
            self.first = batch[0][0].tolist()

    def on_validation_epoch_end(self, trainer, module):  # before the module's hook syncs and resets the metric
        self.local_mse = float(module.psnr_fg.sum_squared_error / module.psnr_fg.total)

    def on_validation_end(self, trainer, module):
        self.val_psnr, self.val_share = float(trainer.callback_metrics["val/psnr"]), len(trainer.val_dataloaders.sampler)

    def on_test_end(self, trainer, module):
        record = {"first_stroke": self.first, "val_share": self.val_share, "val/psnr": self.val_psnr, "local_mse": self.local_mse,
                  "backend": dist.get_backend(), "world_size": trainer.world_size}
        (self.out / f"rank{trainer.global_rank}.json").write_text(json.dumps(record))


if __name__ == "__main__":
    out = Path(sys.argv[1])
    register_configs()
    with initialize_config_dir(str(CONF), version_base="1.3"):
        cfg = compose("train", overrides=[
            "trainer=ddp", "trainer.accelerator=cpu", "trainer.devices=2", "trainer.max_steps=2",
            "renderer=dcgan", "model.channel_mult=0.125", "data.batch_size=8", "data.epoch_size=32", "data.val_size=32",
            "data.test_size=32", "data.num_workers=0", "trainer.num_sanity_val_steps=0", "trainer.log_every_n_steps=1",
            "trainer.enable_progress_bar=false", f"output_dir={out}",
        ])
    train(cfg, callbacks=[Record(out)])
