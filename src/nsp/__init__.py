"""nsp — stroke-based painting: photographs in, paintings of vector brush strokes out."""
import os

# torch's OpenMP threads spin while they wait for each other: with another program busy on a core,
# every parallel op then waits out a time slice, while sleeping at once costs each small op a wake-up.
# So they spin 10,000 turns (libgomp), then sleep (docs/benchmarks.md, "Speed on the paths a user
# takes"). Set before torch loads, unless the user set a policy.
if "OMP_WAIT_POLICY" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"  # what other OpenMP runtimes honour
    os.environ.setdefault("GOMP_SPINCOUNT", "10000")  # libgomp: overrides PASSIVE's 0
# MKL (torch's matrix products on x86) sums in an order that depends on how many threads it finds
# free, so a styled painting differed on a busy machine; its strict mode sums in one order (docs/painting.md).
os.environ.setdefault("MKL_CBWR", "AUTO,STRICT")
# numpy's OpenBLAS starts a thread a core as numpy loads and, where ulimit -u refuses one, raises
# SIGINT (a painting ended as if interrupted). nsp's numpy work is small: one thread, unless set.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"


def paint(image, **options):
    """Paint ``image`` with vector strokes: :func:`nsp.api.paint`, imported on first use so ``import nsp``
    stays instant. Importing the module ``nsp.paint`` rebinds this name to it: call :func:`nsp.api.paint` then."""
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
