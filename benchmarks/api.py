"""The Python API against the command: wall time of the README's ``nsp.paint(...)`` in a fresh process
and of ``python -m nsp.paint`` with the same keys, in turn, the fastest and the median of each.

Both paint, write the same files and score the painting; their PSNRs must match (one config, one
seed). Prints markdown and writes the "Python API against the command" section of docs/benchmarks.md.

    python benchmarks/api.py [--repeats 3] [--strokes 300]
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402

SCRIPT = "import nsp; p = nsp.paint('astronaut', brush='watercolor', strokes={strokes}, out={out!r}, progress=False); print(p.metrics['psnr'])"


def timed(command: list[str]) -> float:
    """Wall seconds of one fresh process running ``command``."""
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--strokes", type=int, default=300)
    args = parser.parse_args()

    times: dict[str, list[float]] = {"api": [], "command": []}
    with tempfile.TemporaryDirectory() as tmp:
        for repeat in range(args.repeats):  # in turn, so a drift of the machine touches both alike
            api, command = Path(tmp) / f"api{repeat}", Path(tmp) / f"command{repeat}"
            times["api"].append(timed([sys.executable, "-c", SCRIPT.format(strokes=args.strokes, out=str(api))]))
            times["command"].append(timed([sys.executable, "-m", "nsp.paint", "image=astronaut", "brush=watercolor",
                                           f"strokes={args.strokes}", "progress=false", f"hydra.run.dir={command}"]))
        psnr = {name: json.loads((Path(tmp) / f"{name}0" / "metrics.json").read_text())["psnr"] for name in times}
    rows = ["| route | fastest (s) | median (s) | PSNR (dB) |", "|---|---:|---:|---:|",
            f"| `nsp.paint('astronaut', brush='watercolor', strokes={args.strokes})` in a fresh `python -c` | "
            f"{min(times['api']):.2f} | {statistics.median(times['api']):.2f} | {psnr['api']:.2f} |",
            f"| `python -m nsp.paint image=astronaut brush=watercolor strokes={args.strokes}` | "
            f"{min(times['command']):.2f} | {statistics.median(times['command']):.2f} | {psnr['command']:.2f} |"]
    ratio = min(times["api"]) / min(times["command"])
    body = "\n".join([
        f"The README's Python route and the command, each a fresh process painting the same {args.strokes} watercolor "
        f"strokes and writing the same files, run in turn {args.repeats} times, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. "
        f"Fastest API / fastest command: {ratio:.2f}.",
        "",
        "Command: `python benchmarks/api.py`  ",
        f"Machine: {machine()}, no GPU, nothing else running; {time.strftime('%Y-%m-%d')}",
        "",
        *rows,
    ])
    write_section("Python API against the command", body)
    print(body)


if __name__ == "__main__":
    main()
