"""Which device the engine runs on: ``cpu``, ``cuda`` (``cuda:N``) or ``auto``, checked up front."""
from __future__ import annotations

import torch
from torch import Tensor

from nsp.errors import BadInput


def resolve_device(name: str, key: str = "device") -> torch.device:
    """``auto``: the first CUDA GPU torch sees, else the CPU. Raises :class:`BadInput` for a
    device torch does not know or cannot reach here."""
    name = str(name).strip().lower()
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError:
        raise BadInput(f"{key}={name}: not a device; expected cpu, cuda, cuda:N or auto") from None
    if device.type == "cuda":
        count = torch.cuda.device_count()
        if count == 0:
            raise BadInput(f"{key}={name}: torch sees no CUDA GPU on this machine; expected {key}=cpu or {key}=auto")
        if (device.index or 0) >= count:
            raise BadInput(f"{key}={name}: this machine has {count} CUDA GPU(s), cuda:0 to cuda:{count - 1}")
    elif device.type != "cpu":
        raise BadInput(f"{key}={name}: nsp runs on cpu or cuda; expected cpu, cuda, cuda:N or auto")
    return device


def to_device(tensor: Tensor, device: torch.device) -> Tensor:
    """A tensor of the host's on ``device``, the host not waiting: on a GPU it is pinned and copied
    asynchronously (a plain copy from the host's memory waits for the device's queue to drain)."""
    pinned = device.type == "cuda" and tensor.device.type == "cpu"
    return (tensor.pin_memory() if pinned else tensor).to(device, non_blocking=True)
