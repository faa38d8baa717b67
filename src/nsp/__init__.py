"""nsp — stroke-based painting: photographs in, paintings of vector brush strokes out."""
import os

# torch's OpenMP threads spin while they wait for each other: with another program busy on one of
# two cores, every parallel op then waits out a time slice (a 1000-stroke render: 20-32 s instead of
# 1.5 s on one 2-core host, 2x on another). Sleeping at once instead costs each small op a wake-up:
# up to twice the time of an idle machine's renders. So they spin 10,000 turns (tens of microseconds; libgomp, torch's on
# Linux), then sleep (docs/benchmarks.md, "Speed on the paths a user takes"). Set before torch loads,
# unless the user set a policy.
if "OMP_WAIT_POLICY" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"  # what other OpenMP runtimes honour
    os.environ.setdefault("GOMP_SPINCOUNT", "10000")  # libgomp: overrides PASSIVE's 0
# MKL (torch's matrix products on x86) sums in an order that depends on how many threads it finds
# free, so a styled painting came out different on a busy machine (a sweep's jobs side by side) than
# on an idle one. Its strict mode sums in one order: the same strokes either way (the painter's are
# the same bytes in both modes, the demo's and 2000 watercolor strokes'; docs/painting.md).
os.environ.setdefault("MKL_CBWR", "AUTO,STRICT")
# numpy's OpenBLAS starts a thread a core as numpy loads and, where a limit on processes (ulimit -u)
# refuses one, raises SIGINT: a painting then ended as if interrupted (exit 130). nsp's numpy work is
# small (torch's own threads do the sums), so OpenBLAS gets one thread unless the user set a count.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"


def paint(image, **options):
    """Paint ``image`` with vector strokes: :func:`nsp.api.paint` (imported here on first use, so
    ``import nsp`` stays instant). ``python -m nsp.paint`` is the command; a program that imports the
    module ``nsp.paint`` itself rebinds this name to it: call :func:`nsp.api.paint` there."""
    from nsp.api import paint as api

    return api(image, **options)


def load(path, metrics=None):
    """A painting from its ``strokes.json``: :func:`nsp.api.load`."""
    from nsp.api import load as api

    return api(path, metrics)


def train(**options):
    """Train a neural renderer; its metrics: :func:`nsp.api.train` (``python -m nsp.train`` is the command)."""
    from nsp.api import train as api

    return api(**options)
