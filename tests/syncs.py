"""Counting the calls that make a host wait for its device: on a GPU, each of these copies a result
back (a number, a size, a list) and stalls the queue of work behind it. Counted on the CPU, where
nothing waits, by a :class:`torch.overrides.TorchFunctionMode` that sees every call made from Python."""
from __future__ import annotations

import collections
import traceback
from pathlib import Path

import torch
from torch import Tensor
from torch.overrides import TorchFunctionMode

import nsp

SRC = Path(nsp.__file__).parent
READS = {Tensor.item, Tensor.tolist, Tensor.numpy, Tensor.cpu, Tensor.__bool__, Tensor.__int__, Tensor.__float__,
         Tensor.__index__, Tensor.__format__}  # a value the host reads
SIZED = {Tensor.nonzero, torch.nonzero, Tensor.masked_select, torch.masked_select, Tensor.unique, torch.unique,
         Tensor.bincount, torch.bincount}  # a result whose size depends on the values
INDEXING = {Tensor.__getitem__, Tensor.__setitem__, Tensor.index_put_, Tensor.index_put}  # by a mask: sized as nonzero


def _masked(index) -> bool:
    parts = index if isinstance(index, (tuple, list)) else (index,)
    return any(isinstance(p, Tensor) and p.dtype == torch.bool and p.dim() > 0 for p in parts)


def _waits(func, args: tuple, kwargs: dict) -> bool:
    if func in READS or func in SIZED:
        return True
    if func in INDEXING:
        return _masked(args[1])
    if func in (Tensor.repeat_interleave, torch.repeat_interleave):  # by a tensor of repeats, without output_size
        repeats = args[1] if len(args) > 1 else kwargs.get("repeats")
        return isinstance(repeats, Tensor) and repeats.numel() > 1 and kwargs.get("output_size") is None
    return False


class HostWaits(TorchFunctionMode):
    """``with HostWaits() as waits: ...`` counts, in :attr:`where`, the calls under it that wait for
    the device, by the line of nsp that made them (``file:line``), or ``elsewhere``."""

    def __init__(self):
        super().__init__()
        self.where: collections.Counter[str] = collections.Counter()

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        if _waits(func, args, kwargs):
            self.where[_caller()] += 1
        return func(*args, **kwargs)

    @property
    def total(self) -> int:
        return sum(self.where.values())


def _caller() -> str:
    for frame in reversed(traceback.extract_stack(limit=40)):
        if frame.filename.startswith(str(SRC)):
            return f"{Path(frame.filename).relative_to(SRC)}:{frame.lineno}"
    return "elsewhere"
