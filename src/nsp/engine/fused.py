"""The engine's compiled path: stroke shading fused by TorchInductor, and when it pays.

Shading runs a few hundred elementwise ops a pixel (a Bézier brush solves a cubic and scans its
swept discs); eager PyTorch makes one pass over memory per op, TorchInductor fuses them into one
loop, 3–5× faster on a CPU. Compiling costs time: about a minute the first time a brush is used
at a canvas size on a machine, then a few seconds a process to load the kernels from the on-disk
cache (``$TORCHINDUCTOR_CACHE_DIR``, by default ``~/.cache/nsp/inductor``, kept across runs and
reboots). :func:`pays` weighs that against the eager time a render is expected to take.
"""
from __future__ import annotations

import functools
import json
import os
from pathlib import Path

import torch
from torch import Tensor

from nsp.brushes.base import Brush

CACHE = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "nsp"
os.environ.setdefault("TORCHINDUCTOR_CACHE_DIR", str(CACHE / "inductor"))  # read when Inductor first compiles

# Eager rendering, nanoseconds per pixel of the strokes' bounding boxes (a stroke's culled tiles are
# a fraction of its box), and the share of it the compiled path takes: 2 threads of this project's
# 2-core CPU, `paint_canvas` of 3000 moderate strokes (benchmarks/engine.py's) at 512 px, timed both ways.
EAGER_NS = {"watercolor": 150.0, "markerpen": 95.0, "tape": 80.0, "oilpaint": 60.0}
COMPILED_SHARE = {"watercolor": 0.25, "markerpen": 0.4, "tape": 0.45, "oilpaint": 1.0}  # oil: its texture lookup
# breaks the graph, and each new batch size recompiles the rest: never worth it end to end
WARM_SECONDS = 7.0  # loading cached kernels (dynamo re-traces the shading): 6–8.5 s, benchmarks/render.py T(1)
COLD_SECONDS = 90.0  # compiling them the first time


def _key(brush: Brush, height: int, width: int, softness: float | None) -> str:
    return f"{torch.__version__} {brush.name} {brush.texture_path} {height}x{width} {softness}"


@functools.cache
def _compiled_keys() -> set[str]:
    """The (brush, size, softness) kernels this machine has compiled, as ``compiled.json`` lists them."""
    try:
        return set(json.loads((CACHE / "compiled.json").read_text()))
    except (OSError, ValueError):
        return set()


def _remember(key: str) -> None:
    keys = _compiled_keys()
    keys.add(key)
    try:
        CACHE.mkdir(parents=True, exist_ok=True)
        (CACHE / "compiled.json").write_text(json.dumps(sorted(keys), indent=1))
    except OSError:
        pass  # a read-only home: later runs just expect a cold compile


def pays(brush: Brush, strokes: Tensor, height: int, width: int, softness: float | None = None) -> bool:
    """Whether rendering ``strokes`` (N, d) on a ``height``×``width`` canvas is expected to finish
    sooner compiled (its start-up included, warm or cold) than eager. Never while gradients flow,
    nor off the CPU (the estimates are the CPU's)."""
    if strokes.device.type != "cpu" or (strokes.requires_grad and torch.is_grad_enabled()):
        return False
    eager = float(brush.box_area(strokes, height, width).sum()) * EAGER_NS.get(brush.name, EAGER_NS["watercolor"]) * 1e-9
    start = WARM_SECONDS if _key(brush, height, width, softness) in _compiled_keys() else COLD_SECONDS
    return eager * (1 - COMPILED_SHARE.get(brush.name, 1.0)) > start


@functools.cache
def _shading(stage):
    torch._dynamo.config.recompile_limit = max(torch._dynamo.config.recompile_limit, 64)  # a graph per brush and size
    return torch.compile(stage, dynamic=False)


def fused(stage, brush: Brush, x: Tensor, t: Tensor, *args, height: int, width: int, softness: float | None):
    """``stage(brush, x, t, *args)`` compiled, x (P, d) and t (P,) pairs: P is the one dynamic size,
    so a graph serves every batch at a canvas size."""
    if len(x) < 2:  # a dynamic size may not be 0 or 1
        return stage(brush, x, t, *args)
    torch._dynamo.maybe_mark_dynamic(x, 0)
    torch._dynamo.maybe_mark_dynamic(t, 0)
    out = _shading(stage)(brush, x, t, *args)
    key = _key(brush, height, width, softness)
    if key not in _compiled_keys():
        _remember(key)
    return out
