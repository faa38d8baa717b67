"""``python -m nsp.engine [BRUSH ...] [--width PX ...]``: compile the kernels a painting with each
named brush (default: all) uses into this machine's kernel cache, a job a core
(:func:`~nsp.engine.precompile.compile_for_painting`), so paintings take them from their first run
(``compile`` left to auto). A brush whose kernels cannot be compiled here is named and skipped: its
strokes are then shaded eagerly. Kernels already in the cache are checked, not compiled again."""
from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed

import torch

from nsp.brushes import BRUSHES
from nsp.engine import fused
from nsp.engine.precompile import compile_for_painting


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m nsp.engine",
        description="Compile the kernels a painting with each named brush uses (default: every brush) into this "
                    "machine's kernel cache, once a machine; make setup compiles the demo's (oilpaint).")
    parser.add_argument("brushes", nargs="*", metavar="BRUSH", help=f"one of {', '.join(BRUSHES)} (default: all)")
    parser.add_argument("--width", type=int, action="append", metavar="PX",
                        help="the width of a painting's files to compile for, where a brush draws them with more detail "
                             "(oil's bristles); repeatable (default: "
                             f"{' and '.join(map(str, fused.FILE_WIDTHS))}, a painting's on its defaults)")
    args = parser.parse_args(argv)
    if unknown := [name for name in args.brushes if name not in BRUSHES]:
        print(f"error: no brush {', '.join(map(repr, unknown))}; expected one of: {', '.join(BRUSHES)}", file=sys.stderr)
        return 2
    if any(width < 1 for width in args.width or ()):
        print("error: --width: expected a positive number of pixels", file=sys.stderr)
        return 2
    names = list(dict.fromkeys(args.brushes)) or list(BRUSHES)
    widths = tuple(dict.fromkeys(args.width or fused.FILE_WIDTHS))
    print(f"the painter's kernels of {', '.join(names)} in {fused.CACHE}: compiled where missing (once a machine, "
          "20–60 s a kernel set), checked where there…", flush=True)
    jobs = [(name, None) for name in names]
    for name in names:  # a job a detail: widths drawn alike share one kernel
        details: dict[str, int] = {}
        for width in widths:
            if BRUSHES[name].varies(width):
                details.setdefault(BRUSHES[name].sized(width).variant, width)
        jobs += [(name, width) for width in details.values()]
    spawn = multiprocessing.get_context("spawn")
    # A job a core, each on one thread (set in each worker: spawned, it starts a fresh torch), so jobs never contend.
    with ProcessPoolExecutor(min(len(jobs), os.cpu_count() or 1), mp_context=spawn,
                             initializer=torch.set_num_threads, initargs=(1,)) as pool:
        for done in as_completed([pool.submit(compile_for_painting, *job) for job in jobs]):
            print(done.result(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
