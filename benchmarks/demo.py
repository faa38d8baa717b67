"""The demo's command and which of its parts use the machine's cores: ``python -m nsp.paint`` (astronaut,
500 oil strokes) at ``threads=1`` and at its default (every core), in turn, each phase's seconds, on
the idle machine and beside as many CPU-bound processes (a ``while`` loop until this script ends) as it has cores.

A phase is what the command's last line reports (painting; writing final.png, painting.svg,
animation.gif), the rest (start-up: Python, the imports, Hydra, the checks) the wall time less
those. The fastest of ``--repeats`` fresh processes per setting; PSNRs beside (a thread count may
round differently, so a painting may differ in its last digits). With ``--base``, the default
setting also runs against another checkout, A and B in turn on the idle machine: the host's speed
drifts through the day, and a ratio taken in turn holds across it. Writes the "The demo, and what
uses the cores" section of docs/benchmarks.md.

    python benchmarks/demo.py [--repeats 3] [--base /tmp/base --base-name NAME]
"""
from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402
from painter import paint_once  # noqa: E402

HERE = Path(__file__).resolve().parent.parent
SETTINGS = {"threads=1": ["threads=1"], f"default ({os.cpu_count()} cores)": []}
FILES = re.compile(r"wrote the files in ([0-9.]+) s")


def measure(repeats: int, tmp: Path) -> dict[str, dict]:
    """The fastest run of each setting, the settings in turn: wall, painting and files seconds, PSNR."""
    best: dict[str, dict] = {}
    for _ in range(repeats):
        for name, overrides in SETTINGS.items():
            out = tmp / "run"
            run = paint_once("astronaut", "oilpaint", 500, out, overrides=overrides)
            files = float(FILES.findall((out / "paint.log").read_text())[-1])
            if name not in best or run["wall"] < best[name]["wall"]:
                best[name] = {"wall": run["wall"], "painting": run["painting"], "files": files,
                              "psnr": run["metrics"]["psnr"]}
    return best


def in_turn(base: Path, repeats: int, tmp: Path) -> dict[str, list[float]]:
    """The demo's wall seconds on its defaults, this checkout (A) and ``base`` (B) in turn, ``repeats`` each."""
    walls: dict[str, list[float]] = {"A": [], "B": []}
    for _ in range(repeats):
        for side, src in (("A", HERE / "src"), ("B", base.resolve() / "src")):
            os.environ["PYTHONPATH"] = str(src)  # the subprocess imports this checkout's nsp
            walls[side].append(paint_once("astronaut", "oilpaint", 500, tmp / "run")["wall"])
    del os.environ["PYTHONPATH"]
    return walls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="fresh processes per setting (the fastest counts)")
    parser.add_argument("--base", type=Path, help="another checkout (B), timed in turn with this one on the defaults")
    parser.add_argument("--base-name", default="B", help="what the docs call B (e.g. its commit)")
    args = parser.parse_args()
    rows = ["| machine | threads | wall (s) | painting (s) | files (s) | the rest (s) | PSNR (dB) |",
            "|---|---|---:|---:|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        for load in ("idle", f"beside {os.cpu_count()} busy processes"):
            busy = [subprocess.Popen([sys.executable, "-c", f"import os\nwhile os.getppid() == {os.getpid()}: pass"])
                    for _ in range(os.cpu_count() if load != "idle" else 0)]  # busy while this runs, killed or not
            try:
                best = measure(args.repeats, Path(tmp))
            finally:
                for process in busy:
                    process.kill()
            for name, b in best.items():
                rows.append(f"| {load} | {name} | {b['wall']:.2f} | {b['painting']:.2f} | {b['files']:.2f} "
                            f"| {b['wall'] - b['painting'] - b['files']:.2f} | {b['psnr']:.2f} |")
                print(rows[-1], flush=True)
        walls = None if args.base is None else in_turn(args.base, args.repeats, Path(tmp))
    turns = []
    if walls:
        ratios = [a / b for a, b in zip(walls["A"], walls["B"])]
        turns = ["", f"In turn with {args.base_name} (B), idle, {args.repeats} runs each: A fastest "
                 f"{min(walls['A']):.2f} s, median {statistics.median(walls['A']):.2f} s; B fastest {min(walls['B']):.2f} s, "
                 f"median {statistics.median(walls['B']):.2f} s; A/B run by run {min(ratios):.3f}–{max(ratios):.3f}, "
                 f"median {statistics.median(ratios):.3f}."]
        print(turns[-1], flush=True)
    base = "" if args.base is None else f" --base B --base-name '{args.base_name}'"
    write_section("The demo, and what uses the cores", "\n".join([
        "`python -m nsp.paint` on its defaults (astronaut, 500 oil strokes), a fresh process each run, the settings in "
        f"turn, the fastest of {args.repeats} each. *painting* and *files* are the times its last line reports; the rest "
        "is start-up (Python, torch, Hydra, the checks; the face search counts as painting). One painting takes every "
        "core by default, and its files are written once it is done, a core each; `threads=1` paints on one. Beside "
        "other CPU-bound work, torch's threads wait on each other: there `threads=1` paints faster, and the whole command takes about as long.", "",
        f"Command: `python benchmarks/demo.py --repeats {args.repeats}{base}`  ",
        f"Machine: {machine()}, no GPU; {time.strftime('%Y-%m-%d')}", "", *rows, *turns]))


if __name__ == "__main__":
    main()
