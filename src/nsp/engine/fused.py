"""The engine's compiled path: its per-pair kernels compiled ahead of time by AOTInductor, kept on disk.

Culling and shading run tens to hundreds of elementwise ops a pixel (a Bézier brush solves a cubic
and scans its swept discs); eager PyTorch makes one pass over memory per op, a compiled kernel one
loop, 1.5–8× faster on a CPU. A kernel of a brush at a canvas size is exported and compiled once
on a machine (15–60 s) into a package under ``~/.cache/nsp/kernels``; later processes load it in
milliseconds.

Whether a render takes this path is its caller's choice, ``compile``: True compiles the kernels this
machine lacks and uses them; None (auto) uses those on disk and draws eagerly where there are none,
saying once a process which ``python -m nsp.engine BRUSH`` compiles them (:func:`choose`); False
never looks at the cache. A kernel loaded from the cache is checked against the eager stage it
stands for, on a sample of the pairs of its first call, before it draws anything: one that draws
otherwise (another brush's or canvas's file under its name) is removed, one that cannot be loaded
(corrupt, or no room to unpack it) is set aside, and the render goes on eagerly either way.
"""
from __future__ import annotations

import errno
import functools
import hashlib
import io
import logging
import os
import shutil
import tempfile
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator

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
MOST_PAIRS = 1 << 24  # the largest batch of (stroke, tile) pairs a kernel takes
HINT_PAIRS = 4096  # the batch it is tuned for: the engine's shading pass at 8-px tiles
PROBE_PAIRS = 64  # pairs of its first call a loaded kernel is checked on against the eager stage
# Canvas widths whose detail the files of a painting on the defaults have: final.png (1024 px long
# side), animation.gif (512 px long side: 384 wide at 3:4; the one kernel serves 171–480 px).
FILE_WIDTHS = (1024, 384)
IDENTITY = "nsp.kernel"  # the package metadata naming what a kernel was compiled for (its cache path)

# The loader unpacks a package's shared library into the temporary dir before it loads it; on a disk
# without room for that it fails, so it is not asked to: this many times the package, and this much more.
UNPACK_FACTOR, UNPACK_MARGIN = 4, 16 << 20
COMPILE_ROOM = 32 << 20  # free room a compile needs in the cache: its package is 1.5–2.5 MB
# What the loader says when the disk, not the file, is at fault: the file is kept.
DISK_FAULTS = ("write callback failed", "temporary directory", "Failed to create directory", "No space left")

# torch._inductor.aoti_load_package wraps this loader, but importing torch._inductor takes ~1.5 s, longer than most renders.
_Loader = torch._C._aoti.AOTIModelPackageLoader

_LOCK = threading.RLock()  # one thread loads, checks or compiles a kernel at a time (final.png's and the GIF's)
_LOADED: dict[tuple, tuple[Any, bool]] = {}  # by _key: the loaded kernel, and whether an informative check passed
_FAILED: dict[tuple, str] = {}  # kernels this process draws without, and why (so a render asks once, not each call)
_ON_DISK: dict[tuple, bool] = {}  # what choose() found in the cache
_TOLD: set[str] = set()  # brushes whose missing kernels this process has named


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


def _identity(path: Path) -> str:
    """What a kernel at ``path`` was compiled for, as its package's metadata records it."""
    return path.relative_to(CACHE).as_posix()


def _key(stage, brush: Brush, consts: dict, device: torch.device) -> tuple:
    return (CACHE, stage, brush.name, brush.d, brush.variant, tuple(sorted(consts.items())), device)


def shading(brush: Brush, x: Tensor, height: int, width: int, softness: float | None = None,
            tile: int = 8) -> list[tuple[Any, Brush, dict]]:
    """The kernels (stage, brush, constants) that shade strokes ``x`` (N, d) on a ``height``×``width``
    canvas on the compiled path: one of every canvas size where the brush has a
    :meth:`~nsp.brushes.Brush.sized` form (with its gradient's, while gradients flow), else one of
    this canvas (:func:`nsp.engine.raster.rasterize`)."""
    if (sized := brush.sized(width)) is None:
        return [(shade_tiles, brush, dict(height=height, width=width, tile=tile, softness=softness))]
    consts = dict(softness=softness, tile=tile)
    grad = x.requires_grad and torch.is_grad_enabled()
    return [(shade_any_size, sized, consts)] + ([(shade_any_size_grad, sized, consts)] if grad else [])


def choose(compile: bool | None, brush: Brush, x: Tensor, height: int, width: int, softness: float | None = None,
           tile: int = 8) -> bool:
    """Whether rendering strokes ``x`` (N, d) on a ``height``×``width`` canvas takes the compiled
    path: ``compile`` itself where it is True or False; where it is None (auto), whether this
    machine has the kernels of its :func:`shading` (on the CPU: those are the ones
    ``python -m nsp.engine`` compiles). Where it has not, the first such render of a process says
    once, in one line, which command compiles them; no timing decides."""
    if compile is not None:
        return bool(compile)
    if x.device.type != "cpu":
        return False
    for stage, shaded, consts in shading(brush, x, height, width, softness, tile):
        key = _key(stage, shaded, consts, x.device)
        if key in _LOADED:
            continue
        if key in _FAILED:  # said when it failed
            return False
        if key not in _ON_DISK:
            _ON_DISK[key] = package(stage, shaded, consts, x.device).exists()
        if not _ON_DISK[key]:
            _tell(brush, package(stage, shaded, consts, x.device), width)
            return False
    return True


def _tell(brush: Brush, missing: Path, width: int) -> None:
    """Say, once a process for each brush, that its kernels are not on disk, and how to compile them."""
    with _LOCK:
        if brush.name in _TOLD:
            return
        _TOLD.add(brush.name)
    command = engine_command(brush.name, missing, width)
    how = (f"`{command}` compiles them, once a machine" if command is not None
           else "compile=true compiles them where they are first used, 20–60 s once")
    log.warning(f"compiled kernels: {brush.name}'s are not on this machine; rendering eagerly ({how})")


def painting_kernels(name: str, widths: tuple[int, ...] | None = None) -> list[tuple[Any, Brush, dict]]:
    """The kernels (stage, brush, constants) ``python -m nsp.engine name`` compiles: without
    ``widths``, the painter's (its soft shading at its own softness and that shading's gradient, and
    its plain paint's antialiased shading); with them, the antialiased shading of the files of those
    widths, where the brush draws them with more detail (oil's bristles). All of any canvas size."""
    brush = brushes.BRUSHES[name]
    if widths is None:
        soft, plain = brush.sized(32), brush.plain().sized(32)  # compile_for_painting's canvases
        return [(shade_any_size, soft, dict(softness=brush.softness, tile=8)),
                (shade_any_size_grad, soft, dict(softness=brush.softness, tile=8)),
                (shade_any_size, plain, dict(softness=None, tile=8))]
    return [(shade_any_size, brush.sized(width).sized(32), dict(softness=None, tile=8)) for width in widths
            if brush.varies(width)]


def engine_command(name: str, missing: Path, width: int) -> str | None:
    """The ``python -m nsp.engine`` command line that compiles the kernel at ``missing`` (one a
    render of a canvas ``width`` px wide with the brush ``name`` uses), or None where none does (a
    brush of other parameters, another softness, a user's texture)."""
    if name not in brushes.BRUSHES:
        return None
    cpu = torch.device("cpu")
    for widths, option in ((None, ""), (FILE_WIDTHS, ""), ((width,), f" --width {width}")):
        if any(package(stage, brush, consts, cpu) == missing for stage, brush, consts in painting_kernels(name, widths)):
            return f"python -m nsp.engine {name}{option}"
    return None


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
    which stand for their dtypes and trailing shapes only; ``fixed``: those after them, as given.
    The package records its own path (:data:`IDENTITY`), and is written by Python from memory: torch's
    package writer, writing a file on a full disk, fails again in its destructor and aborts the process."""
    # On the CPU, torch's C++ builder finding a CUDA toolkit without a GPU is no news to a painter.
    logging.getLogger("torch.utils.cpp_extension").setLevel(logging.ERROR)
    from torch._inductor import aoti_compile_and_package  # imported only to compile: ~1.5 s
    from torch._inductor import config as inductor
    from torch.fx.experimental.proxy_tensor import make_fx

    path = package(stage, brush, consts, device)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path.parent, COMPILING)  # of compiles killed part-way
    if shutil.disk_usage(path.parent).free < COMPILE_ROOM:  # found before a compile's half-minute, not after
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path.parent))
    paired = tuple(p[:1].expand(HINT_PAIRS, *p.shape[1:]).contiguous() for p in paired)
    pairs = torch.export.Dim("pairs", min=2, max=MOST_PAIRS)
    with torch.no_grad():
        stage(brush, *paired, *fixed, **consts)  # eagerly first: state a brush builds lazily (a texture) is then a constant
        # Traced below autograd first, so a stage that differentiates (shade_any_size_grad) is one graph of aten ops.
        graph = make_fx(functools.partial(stage, brush, **consts), tracing_mode="symbolic")(*paired, *fixed)
        program = torch.export.export(_Traced(graph), (*paired, *fixed),  # forward's *tensors
                                      dynamic_shapes=(tuple({0: pairs} for _ in paired) + (None,) * len(fixed),))
        # Parallel loops on as many threads as torch has when the kernel runs (all cores, or a sweep's one),
        # not as it had when compiled (a test's or a compile job's one thread: serial loops for good).
        made = io.BytesIO()
        with inductor.patch({"cpp.threads": os.cpu_count() or 1, "cpp.dynamic_threads": True,
                             "aot_inductor.metadata": {IDENTITY: _identity(path)}}):
            aoti_compile_and_package(program, package_path=made)
    with tempfile.TemporaryDirectory(dir=path.parent, prefix=f"{COMPILING}{os.getpid()}-") as tmp:
        (Path(tmp) / path.name).write_bytes(made.getbuffer())
        os.replace(Path(tmp) / path.name, path)
    return path


def fused(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], *, build: bool = True,
          **consts):
    """``stage(brush, *paired, *fixed, **consts)`` (a function of :mod:`nsp.engine.kernels`) by its
    compiled kernel: the same outputs, for ``paired`` tensors of one row a (stroke, tile) pair
    (x (P, d), t (P,), …) for any number of pairs P, ``fixed`` tensors of the shapes they had then,
    the same ``consts``. ``build``: compile the kernel first where this machine has none; else, and
    wherever a kernel cannot serve (:func:`prepare`), the stage runs eagerly."""
    kernel = _ready(stage, brush, paired, fixed, consts, build)
    if kernel is None:
        return stage(brush, *paired, *fixed, **consts)
    out = kernel.boxed_run([p.contiguous() for p in paired] + list(fixed))
    return out[0] if len(out) == 1 else tuple(out)


def prepare(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], *, build: bool = True,
            **consts) -> bool:
    """Whether :func:`fused` of these arguments runs its compiled kernel: the kernel is loaded (and
    compiled first, with ``build``, where the cache has none) and checked, once a process."""
    return _ready(stage, brush, paired, fixed, consts, build) is not None


def _ready(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], consts: dict, build: bool):
    """The loaded, checked kernel of ``stage`` for these arguments, or None where the stage runs
    eagerly: outside the kernel's batch sizes and dtype, while gradients flow (it has no backward),
    where it is not on disk (and not ``build``), or where it could not be compiled, loaded or trusted
    (said once, in a line; this process then draws without it). With ``build``, a file found
    wanting is removed and compiled afresh, once."""
    x = paired[0]
    if not 2 <= len(x) <= MOST_PAIRS or x.dtype != torch.float32 or (x.requires_grad and torch.is_grad_enabled()):
        return None
    key = _key(stage, brush, consts, x.device)
    if (loaded := _LOADED.get(key)) is not None and loaded[1]:
        return loaded[0]  # a render asks for a kernel thousands of times: it is found and checked once
    if key in _FAILED:
        return None
    with _LOCK:
        if key in _FAILED:
            return None
        path = package(stage, brush, consts, x.device)
        if (loaded := _LOADED.get(key)) is not None:  # its checks so far had nothing to compare: checked again
            kernel, why, bad_file = loaded[0], "", False
        else:
            kernel = None
        for again in (False, True):
            compiled = False
            if kernel is None:
                if not path.exists():
                    if not build:
                        return None
                    if (why := _compile(stage, brush, paired, fixed, consts, x.device)) is not None:
                        return _without(key, why)
                    compiled = True
                kernel, why, bad_file = _load(path, x.device)
            if kernel is not None:
                agrees, informative = _agrees(kernel, stage, brush, paired, fixed, consts)
                if agrees:
                    _LOADED[key] = (kernel, informative)
                    return kernel
                _LOADED.pop(key, None)
                kernel, bad_file = None, True
                why = f"{path.name} does not draw what it is named for (a file of another brush or canvas?)"
            if bad_file:
                _remove(path)
                why += "; removed it"
            if not bad_file or not build or compiled or again:
                return _without(key, why)
            log.warning(f"compiled kernels: {why}, compiling it afresh")


def _compile(stage, brush: Brush, paired, fixed, consts: dict, device: torch.device) -> str | None:
    """Compile a kernel into the cache; None, or why it could not be."""
    try:
        compile_kernel(stage, brush, paired, fixed, consts, device)
    except OSError as err:  # a cache that cannot be written: a read-only or full disk
        return f"cannot write {CACHE} ({err.strerror or err})"
    except Exception as err:  # no C++ compiler, a graph torch cannot export: painting still works, eagerly
        return f"{package(stage, brush, consts, device).name} could not be compiled ({_first_line(err)})"
    return None


def _load(path: Path, device: torch.device) -> tuple[Any, str, bool]:
    """The package at ``path`` loaded, or None, why not and whether the file is at fault (corrupt,
    or compiled for something else), not the disk (no room to unpack it)."""
    unpack = _unpack_dir()
    try:
        room = UNPACK_FACTOR * path.stat().st_size + UNPACK_MARGIN
        if shutil.disk_usage(unpack).free < room:
            return None, f"no room in {unpack} to unpack {path.name} ({room >> 20} MB)", False
        metadata = getattr(_Loader, "load_metadata_from_package", lambda *package: {})  # where torch has it
        recorded = metadata(str(path), "model").get(IDENTITY, _identity(path))
        if recorded != _identity(path):  # compiled by this module for another path: another brush's, canvas's, torch's
            return None, f"{path.name} was compiled for {recorded}", True
        with _unpacked_apart(unpack):
            return _Loader(str(path), "model", False, 1, -1 if device.index is None else device.index), "", False
    except OSError as err:
        return None, f"cannot read {path.name} ({err.strerror or err})", False
    except RuntimeError as err:  # a package that cannot be loaded: truncated, empty, not one; or a full disk
        message = _first_line(err)
        if any(fault in message for fault in DISK_FAULTS):
            return None, f"no room in {unpack} to unpack {path.name} ({message})", False
        return None, f"{path.name} could not be loaded ({message})", True


@contextmanager
def _unpacked_apart(unpack: str) -> Iterator[None]:
    """The loader unpacks a package's library into a dir of its own under the temporary dir, and
    removes it only in its destructor, which a command's process (ended by ``os._exit``) never runs:
    every painting left four such dirs, 1.6 MB each. It unpacks into a dir made here instead, under
    ``unpack``, removed once the library is loaded (mapped: the system keeps it while it is used)."""
    apart = tempfile.mkdtemp(prefix="nsp-unpack-", dir=unpack)
    before = os.environ.get("TMPDIR")
    os.environ["TMPDIR"] = apart  # where the loader's std::filesystem::temp_directory_path looks first
    try:
        yield
    finally:
        if before is None:
            del os.environ["TMPDIR"]
        else:
            os.environ["TMPDIR"] = before
        shutil.rmtree(apart, ignore_errors=True)


def _unpack_dir() -> str:
    """Where the C++ loader unpacks packages: std::filesystem::temp_directory_path on POSIX."""
    return next((os.environ[name] for name in ("TMPDIR", "TMP", "TEMP", "TEMPDIR") if os.environ.get(name)), "/tmp")


def _agrees(kernel, stage, brush: Brush, paired, fixed, consts: dict) -> tuple[bool, bool]:
    """Whether ``kernel`` gives the outputs of the eager ``stage`` on up to :data:`PROBE_PAIRS` of
    ``paired``'s pairs, spread over them (to float rounding: an edge pixel or two may move), and
    whether they had anything to compare (a non-zero output). The kernel reads copies of its inputs
    with room after them: one compiled for wider strokes, or 8-byte integers, reads that room, not
    past its buffers."""
    count = len(paired[0])
    pick = torch.linspace(0, count - 1, min(count, PROBE_PAIRS), device=paired[0].device).round().long()
    sample = [p.detach()[pick].contiguous() for p in paired]
    try:
        got = kernel.boxed_run([_roomy(p) for p in sample] + [_roomy(f) for f in fixed])
    except RuntimeError:  # another stage's: inputs it does not take
        return False, True
    with torch.no_grad():
        want = stage(brush, *sample, *fixed, **consts)
    want = [want] if isinstance(want, Tensor) else list(want)
    if len(got) != len(want):
        return False, True
    for g, w in zip(got, want):
        if g.shape != w.shape or g.dtype != w.dtype:
            return False, True
        g, w = g.double(), w.double()
        close = (g - w).abs() <= 1e-2 * (w.abs() + w.abs().max()) + 1e-6  # False where g is NaN
        if int((~close).sum()) > 4 + 0.01 * w.numel():
            return False, True
    return True, any(bool(w.ne(0).any()) for w in want)


def _roomy(tensor: Tensor) -> Tensor:
    """A copy of ``tensor`` followed in memory by zeros, 3× its size and more."""
    room = tensor.new_zeros(4 * tensor.numel() + 64)
    return room[: tensor.numel()].view(tensor.shape).copy_(tensor)


def _without(key: tuple, why: str) -> None:
    """Draw without the kernel of ``key`` for the rest of this process, saying ``why`` in a line."""
    _FAILED[key] = why
    log.warning(f"compiled kernels: {why}; rendering without it")


def _remove(path: Path) -> None:
    try:
        path.unlink(missing_ok=True)
    except OSError:  # a read-only cache: the next process checks it again
        pass


def _first_line(err: BaseException) -> str:
    return (str(err).strip() or type(err).__name__).splitlines()[0][:300]


def compile_for_painting(name: str, width: int | None = None) -> str:
    """Compile the kernels of any canvas size a painting with the brush ``name`` uses, on one thread
    (:func:`painting_kernels`). Without ``width``: its soft shading (its own softness) and that
    shading's gradient, by a soft render and its backward, and the antialiased shading of its plain
    paint (:meth:`~nsp.brushes.Brush.plain`: the painter's canvases, and the files of brushes with
    no detail finer than their strokes). With ``width``: the antialiased shading of its paint as
    drawn on canvases ``width`` px wide (:meth:`~nsp.brushes.Brush.sized`: oil's bristle scales), a
    painting's files of that detail. Kernels already on disk are loaded and checked, not compiled
    again. What happened, in a line (``python -m nsp.engine``)."""
    from nsp.engine.raster import render  # the engine imports this module

    torch.set_num_threads(1)
    brush, start = brushes.BRUSHES[name], time.perf_counter()
    cpu, kernels_of = torch.device("cpu"), painting_kernels(name, None if width is None else (width,))
    there = all(package(stage, shaded, consts, cpu).exists() for stage, shaded, consts in kernels_of)
    x, what = brush.sample(16, torch.Generator().manual_seed(0)), name if width is None else f"{name} at {width} px"
    try:
        if width is None:
            strokes = x.clone().requires_grad_()
            fg, alpha = render(brush, strokes, 32, softness=brush.softness, compile=True)
            (fg.sum() + alpha.sum()).backward()
        with torch.no_grad():
            render(brush.plain() if width is None else brush.sized(width), x, 32, compile=True)
    except Exception as err:  # painting still works, eagerly
        return f"{what}: not compiled ({type(err).__name__}: {_first_line(err)}); it is drawn eagerly"
    for stage, shaded, consts in kernels_of:
        if (key := _key(stage, shaded, consts, cpu)) not in _LOADED:
            return f"{what}: not compiled ({_FAILED.get(key, 'no render asked for it')}); it is drawn eagerly"
    return f"{what}: already compiled (checked)" if there else f"{what}: {time.perf_counter() - start:.0f} s"
