"""`python -m nsp.render` end to end: strokes/s net of start-up, per brush and engine path.

    python benchmarks/render.py [--repeats 10] [--strokes 6000] [--size 128]

For each brush, a stroke file of N moderate random strokes (engine.py's) and one of its first
stroke are rendered to PNG by the command, each in a fresh process; the rate is
N / (T(N) − T(1)), the best T of ``--repeats`` runs each, so Python's and torch's start-up (and
the compiled path's kernel loading) cancel out. Importing torch varies by a few tenths of a second
from one process to the next, more than the cheaper brushes' N strokes take, so the same is also
timed inside fresh processes from after the imports (``nsp.render.render``: reading the file,
rendering, writing the PNG): t(N) − t(1). The compiled path's cache is warmed first.
Writes the "nsp.render, end to end" section of docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
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

# The reference implementation's OpenCV engine on the same 6000 moderate strokes at 128 px, this
# machine, one core (strokes/s), as the speed issue measured it.
REFERENCE = {"watercolor": 630, "markerpen": 380, "tape": 6600}


# nsp.render's work after its imports, timed in a fresh process: argv strokes, out, size, compile.
INSIDE = """
import sys, time
from omegaconf import OmegaConf
import nsp.engine.canvas, nsp.engine.device, nsp.engine.memory, nsp.io.export, nsp.io.strokes  # render()'s imports
from nsp.render import RenderConfig, render
keys = dict(strokes=sys.argv[1], out=sys.argv[2], size=int(sys.argv[3]), compile=sys.argv[4] == "true")
cfg = OmegaConf.merge(OmegaConf.structured(RenderConfig), keys)
start = time.perf_counter()
render(cfg)
print(time.perf_counter() - start)
"""


def seconds(paths: list[Path], size: int, compile: bool, out: Path, repeats: int) -> tuple[list[float], list[float]]:
    """Best times of ``repeats`` fresh processes per stroke file, the files taken in turn each round,
    so a slower spell of a shared machine falls on all of them alike: the ``nsp.render`` command's
    wall time, and its work after the imports (:data:`INSIDE`)."""
    wall, inside = [float("inf")] * len(paths), [float("inf")] * len(paths)
    flag = str(compile).lower()
    for _ in range(repeats):
        for i, path in enumerate(paths):
            command = [sys.executable, "-m", "nsp.render", f"strokes={path}", f"size={size}", f"out={out}", f"compile={flag}"]
            start = time.perf_counter()
            subprocess.run(command, check=True, capture_output=True)
            wall[i] = min(wall[i], time.perf_counter() - start)
            run = subprocess.run([sys.executable, "-c", INSIDE, str(path), str(out), str(size), flag], check=True,
                                 capture_output=True, text=True)
            inside[i] = min(inside[i], float(run.stdout.split()[-1]))
    return wall, inside


def rate(strokes: int, one: float, many: float, ref: int | None) -> tuple[str, str]:
    """Strokes/s net of start-up, N / (T(N) − T(1)), and its multiple of the reference's rate."""
    if many <= one:  # the strokes took less than the start-up varies by
        return "within start-up noise", "—"
    net = strokes / (many - one)
    return f"{net:,.0f}", f"{net / ref:.1f}×" if ref else "—"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10, help="runs per measurement (the fastest counts)")
    parser.add_argument("--strokes", type=int, default=6000)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--brushes", nargs="+", default=list(BRUSHES), choices=list(BRUSHES))
    args = parser.parse_args()
    rows = ["| brush | engine | T(1) (s) | T(N) (s) | strokes/s net | × reference | after imports: t(1) (s) | t(N) (s) "
            "| strokes/s net | × reference | reference (strokes/s) |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.brushes:
            x = strokes(name, args.strokes, True, torch.device("cpu"))
            files = {}
            for n in (1, args.strokes):
                files[n] = Path(tmp) / f"{name}_{n}.json"
                save_strokes(files[n], StrokeFile(BRUSHES[name], x[:n], args.size, args.size, "white"))
            seconds([files[args.strokes]], args.size, True, Path(tmp) / "warm.png", 1)  # compiles, or loads the cache
            for compile in (False, True):
                wall, inside = seconds([files[1], files[args.strokes]], args.size, compile, Path(tmp) / "out.png",
                                       args.repeats)
                ref = REFERENCE.get(name)
                rows.append(f"| {name} | {'compiled' if compile else 'eager'} | {wall[0]:.2f} | {wall[1]:.2f} "
                            f"| {' | '.join(rate(args.strokes, *wall, ref))} | {inside[0]:.3f} | {inside[1]:.3f} "
                            f"| {' | '.join(rate(args.strokes, *inside, ref))} | {f'{ref:,}' if ref else '—'} |")
                print(rows[-1], flush=True)
    body = (
        f"`python -m nsp.render strokes=F size={args.size} out=x.png compile=false|true`, one fresh process per run, "
        f"{args.strokes:,} moderate random strokes (sizes in the lower quarter of their range, as in the engine "
        f"table) against their first stroke alone: strokes/s net of start-up = N / (T(N) − T(1)), T the best of "
        f"{args.repeats} runs, the two files run in turn. T(1) is the start-up: Python, torch, reading the file, writing the PNG, and on the "
        "compiled path loading the cached kernels (a brush's first compile on a machine takes up to a minute more, once). "
        "Importing torch varies by a few tenths of a second from one process to the next, more than the cheaper brushes' "
        "strokes take, so the same is also timed inside fresh processes from after the imports (`nsp.render.render`: "
        "reading the file, rendering, writing the PNG), t the best of as many runs. "
        "`compile=null`, the default, takes the compiled path only where it is expected to finish sooner "
        "(`nsp.engine.fused.pays`). Reference: the paper's implementation's OpenCV engine on the same strokes, one "
        "core, as the speed issue measured it.\n\n"
        f"Command: `python benchmarks/render.py --repeats {args.repeats} --strokes {args.strokes} --size {args.size}`  \n"
        f"Machine: {machine()}; {time.strftime('%Y-%m-%d')}\n\n" + "\n".join(rows)
    )
    write_section("nsp.render, end to end", body)


if __name__ == "__main__":
    main()
