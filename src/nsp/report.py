"""``python -m nsp.report [DIR]``: tables and plots of training or painting runs, written into DIR
(:func:`~nsp.reporting.write_report`). The reporting modules (TensorBoard's reader, matplotlib) are
imported only once the command line has been read."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from nsp.cli import fail
from nsp.errors import BadInput
from nsp.text import counted

SUMMARY = "Tables and plots of training or painting runs, written into DIR."
EXAMPLES = """examples:
  python -m nsp.report                         # the newest sweep in multirun/
  python -m nsp.report multirun/train/<time>   # a sweep: a row per job
  python -m nsp.report outputs/train/<run>     # one run
"""


def cli(argv: list[str] | None = None) -> None:
    """The command line: ``python -m nsp.report``."""
    parser = argparse.ArgumentParser(prog="python -m nsp.report", description=SUMMARY, epilog=EXAMPLES,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dir", type=Path, nargs="?",
                        help="a multirun's sweep dir, a folder of run dirs or one run's dir "
                             "(default: the newest sweep under multirun/)")
    args = parser.parse_args(argv)
    from nsp.reporting import collect, latest_sweep, write_report

    start = time.perf_counter()
    try:
        report, table, *plots = write_report(args.dir or latest_sweep(Path("multirun")))
    except BadInput as error:
        fail(str(error))
    print(f"reported {counted(len(collect(report.parent)), 'run')} in {time.perf_counter() - start:.1f} s: {report} "
          f"(and {table.name}, {counted(len(plots), 'plot')})")


if __name__ == "__main__":
    cli()
