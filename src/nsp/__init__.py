"""nsp — stroke-based painting: photographs in, paintings of vector brush strokes out."""
import os

# torch's OpenMP threads spin while they wait for each other: with another program busy on one of
# two cores, every parallel op then waits out a time slice, 10-30x slower (a 1000-stroke render:
# 40 s instead of 1.5 s). Sleeping instead costs a few microseconds a wake-up. Set before torch loads.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "0.1.0"
