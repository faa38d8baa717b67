"""How torch's OpenMP threads should wait: `nsp.render` of 6000 strokes under each wait policy, on an
idle machine and beside one CPU-bound process.

    python benchmarks/threads.py [--repeats 5] [--strokes 6000] [--size 128]

Each policy is set in the environment of fresh processes (`import nsp` sets one only where none is
set); the time is nsp.render's work after its imports (benchmarks/render.py's), the best of
``--repeats`` runs, the policies taken in turn each round. Writes the "OpenMP wait policy" section
of docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch

from nsp.brushes import BRUSHES
from nsp.io.strokes import StrokeFile, save_strokes

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402
from engine import strokes  # noqa: E402
from render import INSIDE  # noqa: E402

POLICIES = {  # name -> what the environment sets before `import nsp` (which sets the rest)
    "sleep at once (`OMP_WAIT_POLICY=PASSIVE`)": {"OMP_WAIT_POLICY": "PASSIVE"},
    "spin 10,000 turns, then sleep (nsp's)": {},
    "spin 300,000 turns, then sleep (libgomp's default)": {"GOMP_SPINCOUNT": "300000"},
}
CLEAN = {key: value for key, value in os.environ.items() if key not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
BRUSHES_TIMED = ("tape", "watercolor")


def best(path: Path, size: int, env: dict, repeats: int, out: Path) -> float:
    """The fastest of ``repeats`` fresh processes' render of ``path``, compiled path, after imports."""
    times = []
    for _ in range(repeats):
        run = subprocess.run([sys.executable, "-c", INSIDE, str(path), str(out), str(size), "true"], check=True,
                             capture_output=True, text=True, env=CLEAN | env)
        times.append(float(run.stdout.split()[-1]))
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--strokes", type=int, default=6000)
    parser.add_argument("--size", type=int, default=128)
    args = parser.parse_args()
    rows = ["| machine | policy | " + " | ".join(f"{name} (s)" for name in BRUSHES_TIMED) + " |",
            "|---|---|" + "---:|" * len(BRUSHES_TIMED)]
    with tempfile.TemporaryDirectory() as tmp:
        files = {}
        for name in BRUSHES_TIMED:
            files[name] = Path(tmp) / f"{name}.json"
            x = strokes(name, args.strokes, True, torch.device("cpu"))
            save_strokes(files[name], StrokeFile(BRUSHES[name], x, args.size, args.size, "white"))
            best(files[name], args.size, {}, 1, Path(tmp) / "warm.png")  # compiles, or loads the cache
        for busy in (False, True):
            other = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if busy else None
            try:
                times = {(policy, name): float("inf") for policy in POLICIES for name in BRUSHES_TIMED}
                for _ in range(args.repeats):  # policies in turn: a slower spell falls on all alike
                    for policy, env in POLICIES.items():
                        for name in BRUSHES_TIMED:
                            seconds = best(files[name], args.size, env, 1, Path(tmp) / "out.png")
                            times[policy, name] = min(times[policy, name], seconds)
            finally:
                if other is not None:
                    other.kill()
            for policy in POLICIES:
                cells = " | ".join(f"{times[policy, name]:.3f}" for name in BRUSHES_TIMED)
                rows.append(f"| {'one other busy process' if busy else 'idle'} | {policy} | {cells} |")
                print(rows[-1], flush=True)
    body = (
        f"`nsp.render` of {args.strokes:,} moderate random strokes at {args.size} px on the compiled path, its work "
        "after the imports (reading the file, rendering, writing the PNG) in fresh processes, the best of "
        f"{args.repeats}, under each OpenMP wait policy, on an otherwise idle machine and beside one CPU-bound "
        "process (`python -c \"while True: pass\"`). Spinning waits out a busy core's time slice; sleeping at once "
        "pays a wake-up on every small op. `import nsp` sets the middle one unless `OMP_WAIT_POLICY` is set.\n\n"
        f"Command: `python benchmarks/threads.py --repeats {args.repeats} --strokes {args.strokes} --size {args.size}`  \n"
        f"Machine: {machine()}; {time.strftime('%Y-%m-%d')}\n\n" + "\n".join(rows)
    )
    write_section("OpenMP wait policy", body)


if __name__ == "__main__":
    main()
