"""The engine's compiled path: its per-pair kernels compiled ahead of time by AOTInductor, kept on disk.

Culling and shading run tens to hundreds of elementwise ops a pixel (a Bézier brush solves a cubic
and scans its swept discs); eager PyTorch makes one pass over memory per op, a compiled kernel one
loop, 1.5–8× faster on a CPU. A kernel of a brush at a canvas size is exported and compiled once
on a machine (15–60 s) into a package under ``~/.cache/nsp/kernels``; later processes load it in
milliseconds. :func:`pays` weighs that first compile against the eager time a render would take.
"""
from __future__ import annotations

import functools
import hashlib
import logging
import os
import tempfile
import time
from pathlib import Path

import torch
from torch import Tensor

from nsp import brushes
from nsp.brushes.base import Brush
from nsp.engine import kernels
from nsp.engine.kernels import shade_any_size, shade_any_size_grad, shade_tiles
from nsp.files import remove_leftovers

log = logging.getLogger(__name__)
COMPILING = ".compiling-"  # a compile's working dir in the cache, named with its process id
CACHE = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "nsp" / "kernels"

# Eager rendering, nanoseconds per pixel of the strokes' bounding boxes (a stroke's culled tiles are
# a fraction of its box; `paint_canvas` of 3000 moderate strokes, benchmarks/engine.py's, at 512 px),
# and the share of that time the compiled kernels take (6000 of them at 128 px): 2 threads of this
# project's 2-core CPU. Oil's, where its bristles are drawn: the demo's 500 strokes at 1024–2048 px.
EAGER_NS = {"watercolor": 150.0, "markerpen": 95.0, "tape": 80.0, "oilpaint": 135.0}
COMPILED_SHARE = {"watercolor": 0.15, "markerpen": 0.2, "tape": 0.5, "oilpaint": 0.57}
COMPILE_SECONDS = 120.0  # compiling a brush's culling and shading kernels the first time: 20–60 s here, ×2 for a busy machine
# What the compiled kernels save, ms a stroke painted (benchmarks/quality.py: 5000 strokes, the whole command,
# eager against compiled, 2 threads), and a brush's first compile here, ×2 for busier machines.
SOFT_SAVED_MS = {"oilpaint": 1.7, "watercolor": 3.4, "markerpen": 1.8, "tape": 1.0}
SOFT_COMPILE_SECONDS = {"oilpaint": 42.0, "watercolor": 120.0, "markerpen": 70.0, "tape": 34.0}
MOST_PAIRS = 1 << 24  # the largest batch of (stroke, tile) pairs a kernel takes
HINT_PAIRS = 4096  # the batch it is tuned for: the engine's shading pass at 8-px tiles


def package(stage, brush: Brush, consts: dict, device: torch.device) -> Path:
    """Where the compiled ``stage`` of ``brush`` lives: one file per torch version, version of the
    code it is traced from, stage, brush variant (its parameters, :attr:`~nsp.brushes.Brush.variant`), constants
    (canvas, tiling, edge) and device."""
    fixed = "-".join(f"{key}{consts[key]}" for key in sorted(consts))
    return CACHE / torch.__version__ / _code() / f"{stage.__name__}-{brush.name}{brush.d}-{brush.variant}-{fixed}-{device.type}.pt2"


@functools.cache
def _code() -> str:
    """A digest of the source kernels are traced from (the brushes, the kernels): an edit to it, or
    another release of nsp, compiles afresh instead of loading kernels of the old code."""
    files = sorted(Path(brushes.__file__).parent.glob("*.py")) + [Path(kernels.__file__)]
    return hashlib.sha1(b"".join(path.read_bytes() for path in files)).hexdigest()[:12]


def pays(brush: Brush, strokes: Tensor, height: int, width: int, softness: float | None = None, tile: int = 8) -> bool:
    """Whether rendering ``strokes`` (N, d) on a ``height``×``width`` canvas is expected to finish
    sooner compiled (a first compile included) than eager. Never while gradients flow, nor off the
    CPU (the estimates are the CPU's)."""
    if strokes.device.type != "cpu" or (strokes.requires_grad and torch.is_grad_enabled()):
        return False
    eager = float(brush.box_area(strokes, height, width).sum()) * EAGER_NS.get(brush.name, EAGER_NS["watercolor"]) * 1e-9
    if (sized := brush.sized(width)) is not None:  # one kernel for every canvas of this one's detail
        cached = _any_size_cached(sized, softness, tile, (shade_any_size,))
    else:
        cached = package(shade_tiles, brush, dict(height=height, width=width, tile=tile, softness=softness),
                         strokes.device).exists()
    return eager * (1 - COMPILED_SHARE.get(brush.name, 1.0)) > (0.0 if cached else COMPILE_SECONDS)


class _Traced(torch.nn.Module):
    """A stage's aten graph as a module ``torch.export`` takes."""

    def __init__(self, graph: torch.fx.GraphModule):
        super().__init__()
        self.graph = graph

    def forward(self, *tensors: Tensor):
        return self.graph(*tensors)


def compile_kernel(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], consts: dict,
                   device: torch.device) -> Path:
    """Export and compile ``stage`` into its :func:`package`, written atomically (a concurrent run
    never reads half a file); returns its path. ``paired``: its tensors of one row a pair (x, t, …),
    which stand for their dtypes and trailing shapes only; ``fixed``: those after them, as given."""
    # On the CPU, torch's C++ builder finding a CUDA toolkit without a GPU is no news to a painter.
    logging.getLogger("torch.utils.cpp_extension").setLevel(logging.ERROR)
    from torch._inductor import aoti_compile_and_package  # imported only to compile: ~1.5 s
    from torch._inductor import config as inductor
    from torch.fx.experimental.proxy_tensor import make_fx

    path = package(stage, brush, consts, device)
    paired = tuple(p[:1].expand(HINT_PAIRS, *p.shape[1:]).contiguous() for p in paired)
    pairs = torch.export.Dim("pairs", min=2, max=MOST_PAIRS)
    with torch.no_grad():
        stage(brush, *paired, *fixed, **consts)  # eagerly first: state a brush builds lazily (a texture) is then a constant
        # Traced below autograd first, so a stage that differentiates (shade_any_size_grad) is one graph of aten ops.
        graph = make_fx(functools.partial(stage, brush, **consts), tracing_mode="symbolic")(*paired, *fixed)
        program = torch.export.export(_Traced(graph), (*paired, *fixed),  # forward's *tensors
                                      dynamic_shapes=(tuple({0: pairs} for _ in paired) + (None,) * len(fixed),))
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_leftovers(path.parent, COMPILING)  # of compiles killed part-way
        with tempfile.TemporaryDirectory(dir=path.parent, prefix=f"{COMPILING}{os.getpid()}-") as tmp:
            # Parallel loops on as many threads as torch has when the kernel runs (all cores, or a sweep's one),
            # not as it had when compiled (a test's or a compile job's one thread: serial loops for good).
            with inductor.patch({"cpp.threads": os.cpu_count() or 1, "cpp.dynamic_threads": True}):
                aoti_compile_and_package(program, package_path=str(Path(tmp) / path.name))
            os.replace(Path(tmp) / path.name, path)
    return path


_LOADED: dict[tuple, torch._C._aoti.AOTIModelPackageLoader] = {}  # by cache, stage, brush variant, constants, device


def _kernel(path: Path, device: torch.device) -> torch._C._aoti.AOTIModelPackageLoader:
    # The package's C++ loader, not `torch._inductor.aoti_load_package`, whose import (~1.5 s)
    # takes longer than most renders.
    return torch._C._aoti.AOTIModelPackageLoader(str(path), "model", False, 1, -1 if device.index is None else device.index)


def fused(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], **consts):
    """``stage(brush, *paired, *fixed, **consts)`` (a function of :mod:`nsp.engine.kernels`) by its
    compiled kernel, compiled first if this machine has none: the same outputs, for ``paired``
    tensors of one row a (stroke, tile) pair (x (P, d), t (P,), …) for any number of pairs P,
    ``fixed`` tensors of the shapes they had then, the same ``consts``."""
    x = paired[0]
    if not 2 <= len(x) <= MOST_PAIRS or x.dtype != torch.float32 or (x.requires_grad and torch.is_grad_enabled()):
        return stage(brush, *paired, *fixed, **consts)  # outside the kernel's batch sizes and dtype; it has no backward
    key = (CACHE, stage, brush.name, brush.d, brush.variant, tuple(sorted(consts.items())), x.device)
    if (kernel := _LOADED.get(key)) is None:  # a render asks for a kernel thousands of times: its file is found once
        path = package(stage, brush, consts, x.device)
        try:
            if not path.exists():
                compile_kernel(stage, brush, paired, fixed, consts, x.device)
            kernel = _LOADED[key] = _kernel(path, x.device)
        except OSError as err:  # a cache that cannot be written: this render goes without
            log.warning(f"compiled kernels: cannot write {CACHE} ({err.strerror or err}); rendering without them")
            return stage(brush, *paired, *fixed, **consts)
        except RuntimeError as err:  # a package that cannot be loaded (truncated, empty, not one): compiled afresh next time
            path.unlink(missing_ok=True)
            log.warning(f"compiled kernels: {path.name} could not be loaded ({str(err).splitlines()[0]}); removed it, "
                        "rendering without it")
            return stage(brush, *paired, *fixed, **consts)
    out = kernel.boxed_run([p.contiguous() for p in paired] + list(fixed))
    return out[0] if len(out) == 1 else tuple(out)


def _any_size_cached(brush: Brush, softness: float | None, tile: int, stages) -> bool:
    """Whether the CPU kernels of every size of these ``stages`` of ``brush`` (a
    :meth:`~nsp.brushes.Brush.sized` form) are on disk."""
    consts = {"softness": softness, "tile": tile}
    return all(package(stage, brush, consts, torch.device("cpu")).exists() for stage in stages)


def soft_pays(brush: Brush, softness: float, strokes: int, block: int = 64) -> bool:
    """Whether painting ``strokes`` strokes of ``brush`` on blocks of at most ``block`` px is expected
    to finish sooner with the soft renders shaded by their compiled kernels
    (:class:`~nsp.engine.raster.AnySizeShade`, of any block size; a first compile of both included);
    never where no kernel of any size serves (a user's texture)."""
    if (sized := brush.sized(block)) is None:
        return False
    cached = _any_size_cached(sized, softness, 8, (shade_any_size, shade_any_size_grad))
    return strokes * SOFT_SAVED_MS[brush.name] * 1e-3 > (0.0 if cached else SOFT_COMPILE_SECONDS[brush.name])


def compile_for_painting(name: str, width: int | None = None) -> str:
    """Compile the kernels of any canvas size a painting with the brush ``name`` uses, on one thread.
    Without ``width``: its soft shading (its own softness) and that shading's gradient, by a soft
    render and its backward, and the antialiased shading of its plain paint
    (:meth:`~nsp.brushes.Brush.plain`: the painter's canvases, and the files of brushes with no detail
    finer than their strokes). With ``width``: the antialiased shading of its paint as drawn on
    canvases ``width`` px wide (:meth:`~nsp.brushes.Brush.sized`: oil's bristle scales), a painting's
    files of that detail. What happened, in a line (``python -m nsp.engine``)."""
    from nsp.engine.raster import render  # the engine imports this module

    torch.set_num_threads(1)
    brush, start = brushes.BRUSHES[name], time.perf_counter()
    x, what = brush.sample(16, torch.Generator().manual_seed(0)), name if width is None else f"{name} at {width} px"
    try:
        if width is None:
            strokes = x.clone().requires_grad_()
            fg, alpha = render(brush, strokes, 32, softness=brush.softness, compile=True)
            (fg.sum() + alpha.sum()).backward()
        with torch.no_grad():
            render(brush.plain() if width is None else brush.sized(width), x, 32, compile=True)
    except Exception as err:  # no C++ compiler, a full disk: painting still works, eagerly
        return f"{what}: not compiled ({type(err).__name__}: {(str(err) or '?').splitlines()[0]}); it is drawn eagerly"
    return f"{what}: {time.perf_counter() - start:.0f} s"
