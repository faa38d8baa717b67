"""The engine's compiled path: its per-pair kernels compiled ahead of time by AOTInductor, kept on disk.

Culling and shading run tens to hundreds of elementwise ops a pixel; eager PyTorch makes one pass
over memory per op, a compiled kernel one loop. A kernel of a brush at a canvas size is compiled
once a machine into a package under ``~/.cache/nsp/kernels``, which later processes load.

A render's ``compile``: True compiles the kernels this machine lacks and uses them; None (auto) uses
those on disk and draws eagerly where there are none, saying once a process which ``python -m
nsp.engine BRUSH`` compiles them (:func:`choose`); False never looks at the cache. A loaded kernel is
checked against its eager stage on a sample of its first call's pairs before it draws anything: one
that draws otherwise is removed, one that cannot be loaded is set aside; the render goes on eagerly.
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
from contextlib import contextmanager, suppress
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

# Its public wrapper, torch._inductor.aoti_load_package, imports torch._dynamo: ~1.1 s a painting.
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
    """The kernels (stage, brush, constants) ``rasterize`` shades strokes ``x`` (N, d) with on a
    ``height``×``width`` canvas: one of every canvas size where the brush has a :meth:`~nsp.brushes.Brush.sized`
    form (with its gradient's, while gradients flow), else one of this canvas."""
    if (sized := brush.sized(width)) is None:
        return [(shade_tiles, brush, dict(height=height, width=width, tile=tile, softness=softness))]
    consts = dict(softness=softness, tile=tile)
    grad = x.requires_grad and torch.is_grad_enabled()
    return [(shade_any_size, sized, consts)] + ([(shade_any_size_grad, sized, consts)] if grad else [])


def choose(compile: bool | None, brush: Brush, x: Tensor, height: int, width: int, softness: float | None = None,
           tile: int = 8) -> bool:
    """Whether rendering strokes ``x`` (N, d) on a ``height``×``width`` canvas takes the compiled
    path: ``compile`` itself where it is True or False; where it is None (auto), whether this CPU
    has the kernels of its :func:`shading`, the first render of a process without them saying once
    which command compiles them."""
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
    """The kernels (stage, brush, constants), all of any canvas size, ``python -m nsp.engine name``
    compiles: without ``widths``, the painter's (its soft shading and that shading's gradient, and its
    plain paint's antialiased shading); with them, the antialiased shading of files of those widths
    where the brush draws them with more detail (oil's bristles)."""
    brush = brushes.BRUSHES[name]
    if widths is None:
        soft, consts = brush.sized(32), dict(softness=brush.softness, tile=8)  # 32: python -m nsp.engine's canvases
        return [(shade_any_size, soft, consts), (shade_any_size_grad, soft, consts),
                (shade_any_size, brush.plain().sized(32), dict(softness=None, tile=8))]
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


def fused(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], *, build: bool = True, **consts):
    """``stage(brush, *paired, *fixed, **consts)`` (a function of :mod:`nsp.engine.kernels`) by its
    compiled kernel: the same outputs, for ``paired`` tensors of one row a (stroke, tile) pair
    (x (P, d), t (P,), …) for any number of pairs P, ``fixed`` tensors of the shapes they had then,
    the same ``consts``. ``build``: compile the kernel first where this machine has none; else, and
    wherever a kernel cannot serve (:func:`prepare`), the stage runs eagerly."""
    kernel = _ready(stage, brush, paired, fixed, consts, build)
    if kernel is None:
        return stage(brush, *paired, *fixed, **consts)
    out = kernel.run([p.contiguous() for p in paired] + list(fixed))
    return out[0] if len(out) == 1 else tuple(out)


def prepare(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], *, build: bool = True,
            **consts) -> bool:
    """Whether :func:`fused` of these arguments runs its compiled kernel: the kernel is loaded (and
    compiled first, with ``build``, where the cache has none) and checked, once a process."""
    return _ready(stage, brush, paired, fixed, consts, build) is not None


def _ready(stage, brush: Brush, paired: tuple[Tensor, ...], fixed: tuple[Tensor, ...], consts: dict, build: bool):
    """The loaded, checked kernel of ``stage`` for these arguments, or None where the stage runs eagerly:
    outside the kernel's batch sizes and dtype, while gradients flow (it has no backward), where it is
    not on disk (and not ``build``), or where it could not be compiled, loaded or trusted (said once;
    this process then draws without it). With ``build``, a file found wanting is compiled afresh, once."""
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
        loaded = _LOADED.get(key)  # one loaded whose checks so far had nothing to compare is checked again
        kernel, why, bad_file = (None if loaded is None else loaded[0]), "", False
        for again in (False, True):
            compiled = False
            if kernel is None:
                if not path.exists():
                    if not build:
                        return None
                    try:
                        compile_kernel(stage, brush, paired, fixed, consts, x.device)
                    except OSError as err:  # a cache that cannot be written: a read-only or full disk
                        return _without(key, f"cannot write {CACHE} ({err.strerror or err})")
                    except Exception as err:  # no C++ compiler, a graph torch cannot export: drawn eagerly
                        return _without(key, f"{path.name} could not be compiled ({_first_line(err)})")
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
                with suppress(OSError):  # a read-only cache: the next process checks it again
                    path.unlink(missing_ok=True)
                why += "; removed it"
            if not bad_file or not build or compiled or again:
                return _without(key, why)
            log.warning(f"compiled kernels: {why}, compiling it afresh")


RUNNERS = 2  # threads a loaded kernel runs for at once: final.png's and animation.gif's


class _Kernel:
    """A loaded kernel, run by at most :data:`RUNNERS` threads at once. The loader's run waits for a
    free runner holding the GIL, while a running one may need the GIL to free a tensor: a caller
    beyond its runners would deadlock both, so it waits here instead, the GIL released."""

    def __init__(self, loader):
        self.loader, self.free = loader, threading.BoundedSemaphore(RUNNERS)

    def run(self, tensors: list[Tensor]) -> list[Tensor]:
        with self.free:
            return self.loader.boxed_run(tensors)


def _load(path: Path, device: torch.device) -> tuple[Any, str, bool]:
    """The package at ``path`` loaded, or None, why not and whether the file is at fault (corrupt,
    or compiled for something else), not the disk (no room to unpack it)."""
    # Where the C++ loader unpacks packages: std::filesystem::temp_directory_path on POSIX.
    unpack = next((os.environ[name] for name in ("TMPDIR", "TMP", "TEMP", "TEMPDIR") if os.environ.get(name)), "/tmp")
    try:
        room = UNPACK_FACTOR * path.stat().st_size + UNPACK_MARGIN
        if shutil.disk_usage(unpack).free < room:
            return None, f"no room in {unpack} to unpack {path.name} ({room >> 20} MB)", False
        metadata = getattr(_Loader, "load_metadata_from_package", lambda *package: {})  # where torch has it
        recorded = metadata(str(path), "model").get(IDENTITY, _identity(path))
        if recorded != _identity(path):  # compiled by this module for another path: another brush's, canvas's, torch's
            return None, f"{path.name} was compiled for {recorded}", True
        with _unpacked_apart(unpack):
            return _Kernel(_Loader(str(path), "model", False, RUNNERS, -1 if device.index is None else device.index)), "", False
    except OSError as err:
        return None, f"cannot read {path.name} ({err.strerror or err})", False
    except RuntimeError as err:  # a package that cannot be loaded: truncated, empty, not one; or a full disk
        message = _first_line(err)
        if any(fault in message for fault in DISK_FAULTS):
            return None, f"no room in {unpack} to unpack {path.name} ({message})", False
        return None, f"{path.name} could not be loaded ({message})", True


@contextmanager
def _unpacked_apart(unpack: str) -> Iterator[None]:
    """Have the loader unpack a package's library into a dir made here under ``unpack``, removed once
    the library is loaded (mapped: the system keeps it while used): its own dir is removed only in its
    destructor, which need not run at a process's end (a loader is cached for the process's life)."""
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


def _agrees(kernel, stage, brush: Brush, paired, fixed, consts: dict) -> tuple[bool, bool]:
    """Whether ``kernel`` gives the outputs of the eager ``stage`` on up to :data:`PROBE_PAIRS` of
    ``paired``'s pairs, spread over them (to float rounding: an edge pixel or two may move), and whether
    they had anything to compare (a non-zero output). The kernel reads copies of its inputs with room
    after them: one compiled for wider strokes, or 8-byte integers, reads that room, not past its buffers."""
    count = len(paired[0])
    pick = torch.linspace(0, count - 1, min(count, PROBE_PAIRS), device=paired[0].device).round().long()
    sample = [p.detach()[pick].contiguous() for p in paired]
    try:
        got = kernel.run([_roomy(p) for p in sample] + [_roomy(f) for f in fixed])
    except RuntimeError:  # another stage's: inputs it does not take
        return False, True
    with torch.no_grad():
        want = stage(brush, *sample, *fixed, **consts)
    want = [want] if isinstance(want, Tensor) else list(want)
    if len(got) != len(want) or any(g.shape != w.shape or g.dtype != w.dtype for g, w in zip(got, want)):
        return False, True
    for g, w in zip(got, want):
        g, w = g.double(), w.double()
        close = (g - w).abs() <= 1e-2 * (w.abs() + w.abs().max()) + 1e-6  # False where g is NaN
        if int((~close).sum()) > 4 + 0.01 * w.numel():
            return False, True
    return True, any(bool(w.ne(0).any()) for w in want)


def _roomy(tensor: Tensor) -> Tensor:
    """A copy of ``tensor`` followed in memory by zeros, 3× its size and more."""
    room = tensor.new_zeros(4 * tensor.numel() + 64)
    return room[: tensor.numel()].view(tensor.shape).copy_(tensor)


def why_without(stage, brush: Brush, consts: dict, device: torch.device) -> str | None:
    """Why this process draws ``stage`` of ``brush`` with ``consts`` on ``device`` without its
    kernel, or None where it has loaded and checked it."""
    key = _key(stage, brush, consts, device)
    return None if key in _LOADED else _FAILED.get(key, "no render asked for it")


def _without(key: tuple, why: str) -> None:
    """Draw without the kernel of ``key`` for the rest of this process, saying ``why`` in a line."""
    _FAILED[key] = why
    log.warning(f"compiled kernels: {why}; rendering without it")


def _first_line(err: BaseException) -> str:
    return (str(err).strip() or type(err).__name__).splitlines()[0][:300]
