"""How often a painting reads a value back from its device (on a GPU each read waits for the queue
to drain): torch's ``aten._local_scalar_dense`` (a number) and ``aten.nonzero`` (a size) dispatched
around ``nsp.paint``, by the line of nsp that made them, in the settings a GPU takes (``renderer.static``,
``schedule.static``: true) and with each turned off, after a painting that warms the caches a process
fills once (CPU reads, not the device's). Counted on the
CPU (torch's dispatch mode sees every op whatever the device); what the painting does is the same.
Host data copied to the device (Python values made a tensor there, an index of a Python list, a
``.to(device)`` not asked to be asynchronous) waits as long on a GPU: counted too, by the tests' count.

    python benchmarks/syncs.py [--strokes 300] [--brush watercolor]
"""
from __future__ import annotations

import argparse
import collections
import sys
import traceback
from pathlib import Path

import torch
from torch.utils._python_dispatch import TorchDispatchMode  # torch's documented way to see every op

import nsp

sys.path.insert(0, str(Path(__file__).parents[1] / "tests"))  # before this file's own folder: tests/syncs.py
from syncs import HostWaits  # noqa: E402  (the tests' count of host data copied in)

READS = (torch.ops.aten._local_scalar_dense.default, torch.ops.aten.nonzero.default)
SRC = str(Path(nsp.__file__).parent)


class Reads(TorchDispatchMode):
    def __init__(self):
        super().__init__()
        self.where: collections.Counter[str] = collections.Counter()

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        if func in READS:
            ours = [f for f in traceback.extract_stack() if f.filename.startswith(SRC)]
            self.where[f"{Path(ours[-1].filename).relative_to(SRC)}:{ours[-1].lineno}" if ours else "elsewhere"] += 1
        return func(*args, **(kwargs or {}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--strokes", type=int, default=300)
    parser.add_argument("--brush", default="watercolor")
    args = parser.parse_args()
    nsp.paint("astronaut", strokes=args.strokes, brush=args.brush, progress=False, **{"renderer.compile": False})
    for renderer, schedule in ((True, True), (True, False), (False, False)):  # each after the warm-up above
        with Reads() as reads, HostWaits(copies=True) as copies:
            nsp.paint("astronaut", strokes=args.strokes, brush=args.brush, progress=False,
                      **{"renderer.compile": False, "renderer.static": renderer, "schedule.static": schedule})
        top = ", ".join(f"{where} {count}" for where, count in reads.where.most_common(4))
        print(f"renderer.static={str(renderer).lower()} schedule.static={str(schedule).lower()}: "
              f"{sum(reads.where.values())} reads ({top}, …); {copies.total} copies of host data in "
              f"({', '.join(f'{where} {count}' for where, count in copies.where.most_common(3))}, …)")


if __name__ == "__main__":
    main()
