"""Command-line start-up: wall time of ``python -m nsp.<command> --help`` for the four commands, and
of ``python -m nsp.paint`` until its first line (what it will paint) appears.

Each figure is the fastest and the median of fresh processes (Python's start-up included); on a
shared machine the fastest is the least disturbed. Prints markdown and writes the "Command-line
start-up" section of docs/benchmarks.md.

    python benchmarks/help.py [--repeats 7]
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402

COMMANDS = ("paint", "train", "render", "report")


def help_seconds(name: str) -> float:
    """Wall seconds of one ``python -m nsp.<name> --help``."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", f"nsp.{name}", "--help"], check=True, capture_output=True)
    return time.perf_counter() - start


def first_line_seconds() -> float:
    """Wall seconds from starting ``python -m nsp.paint`` to its first line; the run is then stopped."""
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        run = subprocess.Popen([sys.executable, "-m", "nsp.paint", "progress=false", f"hydra.run.dir={tmp}/run"],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        run.stdout.readline()
        seconds = time.perf_counter() - start
        run.kill()
        run.wait()
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()

    rows = ["| command | fastest (s) | median (s) |", "|---|---:|---:|"]
    cases = [(f"`python -m nsp.{name} --help`", lambda name=name: help_seconds(name)) for name in COMMANDS]
    cases.append(("`python -m nsp.paint`, to its first line", first_line_seconds))
    for label, measure in cases:
        times = [measure() for _ in range(args.repeats)]
        rows.append(f"| {label} | {min(times):.2f} | {statistics.median(times):.2f} |")
        print(rows[-1], flush=True)

    body = "\n".join([
        "Wall time of fresh processes, Python's start-up included: `--help` of each command, which imports "
        "neither torch nor Lightning, and `python -m nsp.paint` until its first line (\"painting astronaut with "
        f"500 oilpaint strokes…\"), printed before torch loads. Fastest and median of {args.repeats} runs, "
        f"{time.strftime('%Y-%m-%d')}.",
        "",
        "Command: `python benchmarks/help.py`  ",
        f"Machine: {machine()}, nothing else running; {time.strftime('%Y-%m-%d')}",
        "",
        *rows,
    ])
    write_section("Command-line start-up", body)
    print(body)


if __name__ == "__main__":
    main()
