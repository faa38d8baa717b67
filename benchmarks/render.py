"""`python -m nsp.render` end to end: strokes/s net of start-up, per brush and engine path, and
against the reference implementation's OpenCV engine on the same strokes, in the same run.

    python benchmarks/render.py [--repeats 10] [--strokes 6000] [--size 128] [--reference PATH]

For each brush, a stroke file of N moderate random strokes (engine.py's) and one of its first
stroke are rendered to PNG by the command, each in a fresh process; the rate is
N / (T(N) − T(1)), the best T of ``--repeats`` runs each, so Python's and torch's start-up (and
the compiled path's kernel loading) cancel out. Importing torch varies by a few tenths of a second
from one process to the next, more than the cheaper brushes' N strokes take, so the same is also
timed inside fresh processes from after the imports (``nsp.render.render``: reading the file,
rendering, writing the PNG): t(N) − t(1). The compiled path's cache is warmed first; a last
column is the first run a new user makes, ``compile`` left to nsp, with an empty kernel cache.

With ``--reference PATH`` (a checkout of github.com/jiupinjia/stylized-neural-painting and OpenCV;
run, never copied), each brush it shares with nsp (watercolor, markerpen, rectangle → tape) also
paints N of the reference's own random strokes by its engine (``benchmarks/reference.py``: its
sampler, its time drawing them), and nsp renders the same strokes from its ``.npz`` as above: the
ratio of the two rates is the only "× reference" printed. Writes the "nsp.render, end to end"
section of docs/benchmarks.md.
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
from nsp.io.strokes import StrokeFile, load_strokes, save_strokes

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402
from engine import strokes  # noqa: E402
from reference import BRUSHES as SHARED, draw  # noqa: E402


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
            wall[i] = min(wall[i], command_seconds(path, size, out, f"compile={flag}"))
            run = subprocess.run([sys.executable, "-c", INSIDE, str(path), str(out), str(size), flag], check=True,
                                 capture_output=True, text=True)
            inside[i] = min(inside[i], float(run.stdout.split()[-1]))
    return wall, inside


def command_seconds(path: Path, size: int, out: Path, *overrides: str, env: dict | None = None) -> float:
    """Wall seconds of one ``python -m nsp.render`` process drawing ``path``."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "nsp.render", f"strokes={path}", f"size={size}", f"out={out}", *overrides],
                   check=True, capture_output=True, env=env)
    return time.perf_counter() - start


def rate(strokes: int, one: float, many: float, ref: float | None) -> tuple[str, str]:
    """Strokes/s net of start-up, N / (T(N) − T(1)), and its multiple of the reference's rate
    measured in this run (None: the reference did not run: "not measured")."""
    if many <= one:  # the strokes took less than the start-up varies by
        return "within start-up noise", "—" if ref else "not measured"
    net = strokes / (many - one)
    return f"{net:,.0f}", f"{net / ref:.1f}×" if ref else "not measured"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10, help="runs per measurement (the fastest counts)")
    parser.add_argument("--strokes", type=int, default=6000)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--brushes", nargs="+", default=list(BRUSHES), choices=list(BRUSHES))
    parser.add_argument("--reference", type=Path, help="a checkout of the reference implementation (with OpenCV)")
    args = parser.parse_args()
    rows = ["| strokes | brush | engine | T(1) (s) | T(N) (s) | strokes/s net | × reference | after imports: t(1) (s) "
            "| t(N) (s) | strokes/s net | × reference | reference (strokes/s, this run) | first run, empty cache: T(N) (s) |",
            "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as tmp:
        sets = [("nsp's moderate", name, strokes(name, args.strokes, True, torch.device("cpu")), None) for name in args.brushes]
        if args.reference is not None:
            for theirs, name in SHARED.items():
                path = Path(tmp) / f"{theirs}.npz"
                ref = args.strokes / draw(args.reference.resolve(), theirs, args.strokes, args.size, path)
                sets.append(("the reference's", name, load_strokes(path, brush=name, size=args.size).strokes, ref))
        for kind, name, x, ref in sets:
            files = {}
            for n in (1, args.strokes):
                files[n] = Path(tmp) / f"{name}_{n}.json"
                save_strokes(files[n], StrokeFile(BRUSHES[name], x[:n], args.size, args.size, "white"))
            with tempfile.TemporaryDirectory() as empty:  # a new user's first render: no kernels cached
                cold = command_seconds(files[args.strokes], args.size, Path(tmp) / "cold.png",
                                       env=os.environ | {"XDG_CACHE_HOME": empty})
            seconds([files[args.strokes]], args.size, True, Path(tmp) / "warm.png", 1)  # compiles, or loads the cache
            for compile in (False, True):
                wall, inside = seconds([files[1], files[args.strokes]], args.size, compile, Path(tmp) / "out.png",
                                       args.repeats)
                rows.append(f"| {kind} | {name} | {'compiled' if compile else 'eager'} | {wall[0]:.2f} | {wall[1]:.2f} "
                            f"| {' | '.join(rate(args.strokes, *wall, ref))} | {inside[0]:.3f} | {inside[1]:.3f} "
                            f"| {' | '.join(rate(args.strokes, *inside, ref))} | {f'{ref:,.0f}' if ref else 'not measured'} "
                            f"| {cold:.1f} |")
                print(rows[-1], flush=True)
    command = f"python benchmarks/render.py --repeats {args.repeats} --strokes {args.strokes} --size {args.size}"
    body = (
        f"`python -m nsp.render strokes=F size={args.size} out=x.png compile=false|true`, one fresh process per run, "
        f"{args.strokes:,} random strokes against their first stroke alone: strokes/s net of start-up = "
        f"N / (T(N) − T(1)), T the best of {args.repeats} runs, the two files run in turn. *nsp's moderate* strokes have "
        "sizes in the lower quarter of their range (as in the engine table); *the reference's* are its own random "
        "sampler's (uniform parameters, the tiniest dropped), drawn by its OpenCV engine in the same run, whose rate "
        "(its time in `draw_stroke`, one core) gives the only \"× reference\" figures. T(1) is the start-up: Python, "
        "torch, reading the file, writing the PNG, and on the compiled path loading the cached kernels. Importing torch "
        "varies by a few tenths of a second from one process to the next, more than the cheaper brushes' strokes take, "
        "so the same is also timed inside fresh processes from after the imports (`nsp.render.render`: reading the "
        "file, rendering, writing the PNG). The last column is a new user's first render: `compile` left to nsp "
        "(the compiled path where the kernels are on disk, eager otherwise: until "
        "2026-11-27, `nsp.engine.fused.pays` chose it where a cost model expected it to finish sooner, a compile included) and no kernels cached.\n\n"
        f"Command: `{command}{' --reference PATH' if args.reference else ''}`"
        f"{' (PATH: a checkout of github.com/jiupinjia/stylized-neural-painting, with OpenCV; run, never copied)' if args.reference else ''}  \n"
        f"Machine: {machine()}; {time.strftime('%Y-%m-%d')}\n\n" + "\n".join(rows)
    )
    write_section("nsp.render, end to end", body)


if __name__ == "__main__":
    main()
