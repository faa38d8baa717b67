"""``python -m nsp.engine``: compile the kernels a painting uses of every brush (the soft shading
and its gradient, :class:`nsp.engine.raster.AnySizeShade`, and the plain paint's antialiased
shading, all of any canvas size) into this machine's kernel cache, so that paintings take them
from their first run (``make setup`` does this once), a brush a core. A brush whose kernels
cannot be compiled here is named and skipped: the painter then shades its strokes eagerly."""
from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed

from nsp.brushes import BRUSHES
from nsp.engine import fused


def main() -> int:
    argparse.ArgumentParser(prog="python -m nsp.engine", description="Compile the kernels a painting uses, of every "
                            "brush, into this machine's kernel cache (make setup does it once).").parse_args()
    print(f"compiling the painter's kernels of {', '.join(BRUSHES)} into {fused.CACHE} "
          "(once a machine, 20–60 s a brush)…", flush=True)
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(min(len(BRUSHES), os.cpu_count() or 1), mp_context=spawn) as pool:
        for done in as_completed([pool.submit(fused.compile_for_painting, name) for name in BRUSHES]):
            print(done.result(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
