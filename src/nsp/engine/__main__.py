"""``python -m nsp.engine``: compile the kernels a painting uses of every brush (the soft shading
and its gradient, :class:`nsp.engine.raster.AnySizeShade`, and the plain paint's antialiased
shading, all of any canvas size), and those of the files of a painting on the defaults where a
brush draws them with more detail (oil's bristles), into this machine's kernel cache, so that
paintings take them from their first run (``make setup`` does this once), a job a core. A brush
whose kernels cannot be compiled here is named and skipped: its strokes are then shaded eagerly."""
from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed

from nsp.brushes import BRUSHES
from nsp.engine import fused

# Canvas widths whose detail the files of a painting on the defaults have: final.png (1024 px long
# side), animation.gif (512 px long side: 384 wide at 3:4; the one kernel serves 171–480 px).
FILE_WIDTHS = (1024, 384)


def main() -> int:
    argparse.ArgumentParser(prog="python -m nsp.engine", description="Compile the kernels a painting uses, of every "
                            "brush, into this machine's kernel cache (make setup does it once).").parse_args()
    print(f"compiling the painter's kernels of {', '.join(BRUSHES)} into {fused.CACHE} "
          "(once a machine, 20–60 s a brush)…", flush=True)
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(min(len(BRUSHES), os.cpu_count() or 1), mp_context=spawn) as pool:
        jobs = [pool.submit(fused.compile_for_painting, name) for name in BRUSHES]
        jobs += [pool.submit(fused.compile_for_painting, name, width) for name, brush in BRUSHES.items()
                 for width in FILE_WIDTHS if brush.varies(width)]
        for done in as_completed(jobs):
            print(done.result(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
