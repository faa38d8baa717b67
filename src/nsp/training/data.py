"""Training data: random strokes drawn on the fly by the vector engine, and a fixed validation set."""
from __future__ import annotations

import math

import pytorch_lightning as L
import numpy as np
import torch
from torch import Tensor
from torch.utils.data import DataLoader, Dataset, DistributedSampler, Sampler, TensorDataset

from nsp.brushes import Brush, get_brush
from nsp.engine import render


def generator(*seed: int) -> torch.Generator:
    """A generator seeded from a tuple of integers (NumPy's ``SeedSequence`` keeps the streams apart)."""
    state = np.random.SeedSequence(seed).generate_state(1, np.uint64)[0]
    return torch.Generator().manual_seed(int(state))


def draw(brush: Brush, n: int, size: int, gen: torch.Generator, chunk: int = 256) -> tuple[Tensor, Tensor, Tensor]:
    """``n`` strokes uniform over the parameter space and their antialiased renderings: x (n, d),
    foreground (n, 3, size, size), alpha (n, 1, size, size)."""
    x = brush.sample(n, generator=gen)
    fg, alpha = zip(*(render(brush, part, size) for part in x.split(chunk)))
    return x, torch.cat(fg), torch.cat(alpha)


class RandomStrokes(Dataset):
    """Item i is batch i of an endless stream of random strokes, seeded by (seed, 0, i), so the stream is
    the same whatever the number of workers or processes: ``(x, foreground, alpha)`` rendered at ``size``
    (by the compiled engine with ``compile``), or x (B, d) alone where ``size`` is None (rendered on the
    training device)."""

    def __init__(self, brush: Brush, batch_size: int, seed: int, size: int | None = None, compile: bool = False):
        self.brush, self.batch_size, self.seed, self.size, self.compile = brush, batch_size, seed, size, compile

    def __getitem__(self, index: int) -> Tensor | tuple[Tensor, Tensor, Tensor]:
        x = self.brush.sample(self.batch_size, generator=generator(self.seed, 0, index))
        return x if self.size is None else (x, *render(self.brush, x, self.size, compile=self.compile))


class EpochSampler(Sampler[int]):
    """Batch indices of one epoch, new ones every epoch (Lightning calls ``set_epoch``), split over ranks.
    ``done``: batches of this epoch trained on before a resume mid-epoch, skipped once so the resumed run
    sees the batches the uninterrupted one would; the length stays the whole epoch's, as Lightning counts
    the restored batches in it."""

    def __init__(self, batches: int, rank: int = 0, world_size: int = 1, done: int = 0):
        self.batches, self.rank, self.world_size, self.epoch, self.done = batches, rank, world_size, 0, done

    def set_epoch(self, epoch: int) -> None:
        if epoch != self.epoch:
            self.epoch, self.done = epoch, 0

    def __len__(self) -> int:
        return len(range(self.rank, self.batches, self.world_size))

    def __iter__(self):
        start = self.epoch * self.batches
        return iter(range(start + self.rank, start + self.batches, self.world_size)[self.done:])


class StrokeData(L.LightningDataModule):
    """Random training strokes of one brush (fresh every epoch), and fixed, seeded validation and test
    sets (streams 1 and 2 of their seeds; training is stream 0), so no choice made on the validation
    strokes scores itself on them. Batches are ``(x (B, d), foreground (B, 3, S, S), alpha (B, 1, S, S))``,
    the training ones rendered by ``num_workers`` loader processes, or with ``render_on_device`` on the
    training device after the transfer (a GPU draws its own data).
    """

    def __init__(self, brush: str, size: int, batch_size: int = 64, epoch_size: int = 50_000, val_size: int = 1024,
                 val_seed: int = 0, test_size: int = 1024, test_seed: int = 0, seed: int = 0, num_workers: int = 0,
                 render_on_device: bool = False, compile: bool = False, texture: str | None = None):
        super().__init__()
        self.brush = get_brush(brush, texture).plain()  # each stroke's mean paint: no network learns a stroke's detail from x
        self.size, self.batch_size = size, batch_size
        self.num_workers, self.render_on_device, self.compile = num_workers, render_on_device, compile
        self.batches = math.ceil(epoch_size / batch_size)
        self.val_size, self.val_seed, self.seed = val_size, val_seed, seed
        self.test_size, self.test_seed = test_size, test_seed

    def setup(self, stage: str) -> None:
        # Each drawn once from its own seed, so every run scores the same strokes.
        if stage in ("fit", "validate") and not hasattr(self, "val_set"):
            self.val_set = TensorDataset(*draw(self.brush, self.val_size, self.size, generator(self.val_seed, 1)))
        if stage == "test" and not hasattr(self, "test_set"):
            self.test_set = TensorDataset(*draw(self.brush, self.test_size, self.size, generator(self.test_seed, 2)))
        size = None if self.render_on_device else self.size
        self.train_set = RandomStrokes(self.brush, self.batch_size, self.seed, size, self.compile)

    def train_dataloader(self) -> DataLoader:
        sampler = EpochSampler(self.batches)
        if self.trainer:  # a resumed run has its epoch and step restored by now: skip the batches trained on
            trainer = self.trainer
            sampler = EpochSampler(self.batches, trainer.global_rank, trainer.world_size)
            sampler.epoch = trainer.current_epoch
            sampler.done = min(max(trainer.global_step - trainer.current_epoch * len(sampler), 0), len(sampler))
        return DataLoader(self.train_set, batch_size=None, sampler=sampler,  # an item is already a batch
                          num_workers=self.num_workers, persistent_workers=self.num_workers > 0)

    def val_dataloader(self) -> DataLoader:
        return self.scoring_loader(self.val_set)

    def test_dataloader(self) -> DataLoader:
        return self.scoring_loader(self.test_set)

    def scoring_loader(self, strokes: TensorDataset) -> DataLoader:
        """A fixed set in order; under DDP each rank scores its own share and the metrics are synced."""
        world = self.trainer.world_size if self.trainer else 1
        sampler = DistributedSampler(strokes, shuffle=False) if world > 1 else None
        return DataLoader(strokes, batch_size=self.batch_size, sampler=sampler)

    def on_after_batch_transfer(self, batch, dataloader_idx: int):
        if isinstance(batch, Tensor):  # strokes only (render_on_device): render them where training runs
            return (batch, *render(self.brush, batch, self.size, compile=self.compile))
        return batch
