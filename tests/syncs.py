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
FROM_HOST = {torch.tensor, torch.as_tensor, Tensor.new_tensor}  # a tensor of the host's data: on a GPU, copied in


def _masked(index) -> bool:
    parts = index if isinstance(index, (tuple, list)) else (index,)
    return any(isinstance(p, Tensor) and p.dtype == torch.bool and p.dim() > 0 for p in parts)


def _listed(index) -> bool:
    parts = index if isinstance(index, tuple) else (index,)
    return any(isinstance(p, list) for p in parts)


def _copies(func, args: tuple, kwargs: dict) -> bool:
    """Whether the call copies host data to the working device, which on a GPU waits for its queue
    as a read does, and which a CUDA graph cannot capture: Python values made a tensor on a device,
    an index of a Python list, a move to a device not asked to be asynchronous (``non_blocking``)."""
    if func in FROM_HOST:  # device="cpu", a string: the host's own bookkeeping
        device = kwargs.get("device")
        return device is not None and not (isinstance(device, str) and device == "cpu")
    if func in INDEXING:
        return _listed(args[1])
    if func is Tensor.to:
        moved = any(isinstance(a, (torch.device, str)) for a in args[1:]) or "device" in kwargs
        return moved and not kwargs.get("non_blocking", False)
    return False


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
    the device, by the line of nsp that made them (``file:line``), or ``elsewhere``; with
    ``copies``, the calls that copy host data in instead (:func:`_copies`)."""

    def __init__(self, copies: bool = False):
        super().__init__()
        self.where: collections.Counter[str] = collections.Counter()
        self.counts = _copies if copies else _waits

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        if self.counts(func, args, kwargs):
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
