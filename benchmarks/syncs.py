"""How often a painting reads a value back from its device (on a GPU each read waits for the queue
to drain): torch's ``aten._local_scalar_dense`` (a number) and ``aten.nonzero`` (a size) dispatched
around ``nsp.paint``, by the line of nsp that made them, for each ``renderer.static``. Counted on the
CPU (torch's dispatch mode sees every op whatever the device); what the painting does is the same.

    python benchmarks/syncs.py [--strokes 300] [--brush watercolor]
"""
from __future__ import annotations

import argparse
import collections
import traceback
from pathlib import Path

import torch
from torch.utils._python_dispatch import TorchDispatchMode  # torch's documented way to see every op

import nsp

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
    for static in (True, False):
        with Reads() as reads:
            nsp.paint("astronaut", strokes=args.strokes, brush=args.brush, progress=False,
                      **{"renderer.compile": False, "renderer.static": static})
        top = ", ".join(f"{where} {count}" for where, count in reads.where.most_common(4))
        print(f"renderer.static={str(static).lower()}: {sum(reads.where.values())} reads ({top}, …)")


if __name__ == "__main__":
    main()
