"""``python -m nsp.report [DIR]``: tables and plots of a Hydra multirun, a folder of runs or one run.

Writes into DIR ``report.md``, ``report.csv`` (one row per job: swept choices, status, final metrics;
renderer studies also get the renderer × brush table, mean ± std over seeds, beside the paper's),
one ``<tag>.png`` per TensorBoard curve and a bar chart of the final score. Works for ``nsp.train``
and ``nsp.paint`` sweeps alike. Without DIR: the newest sweep under ``multirun/``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nsp.cli import BAD_INPUT
from nsp.reporting import latest_sweep, write_report


def cli(argv: list[str] | None = None) -> None:
    """The command line: ``python -m nsp.report``."""
    parser = argparse.ArgumentParser(prog="python -m nsp.report", description=__doc__.splitlines()[0])
    parser.add_argument("dir", type=Path, nargs="?",
                        help="a multirun's sweep dir (e.g. multirun/renderer_comparison/<time>), a folder of runs or a run dir; default: the newest sweep under multirun/")
    args = parser.parse_args(argv)
    try:
        written = write_report(args.dir or latest_sweep(Path("multirun")))
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(BAD_INPUT)
    for path in written:
        print(path)


if __name__ == "__main__":
    cli()
