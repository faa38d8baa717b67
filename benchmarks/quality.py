"""Time to quality: PSNR against the whole command's wall time, per brush, 200–5000 strokes, this
checkout (A) against another (B), measured in turn on the same host.

For each brush and budget, A and B each run ``python -m nsp.paint image=PHOTO brush=B strokes=N``
in a fresh process, alternately (A B A B …, ``--repeats`` each, one at a time); a point is the
fastest wall time (start-up, painting and files) and metrics.json's PSNR. A runs twice in turn,
on its defaults: with an empty kernel cache (eager: a machine that never compiled) and with the one
``make setup`` leaves (``python -m nsp.engine`` run first into a fresh cache, timed). Writes the table as the "Time to quality" section of docs/benchmarks.md and the
curves to docs/img/time_to_quality.png.

    git worktree add /tmp/base <commit>
    python benchmarks/quality.py --base /tmp/base [--photo astronaut] [--repeats 1]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from doc import machine, write_section  # noqa: E402
from painter import paint_once  # noqa: E402

from nsp.brushes import BRUSHES  # noqa: E402

HERE = Path(__file__).resolve().parent.parent
COMPILED = "A, compiled"
PLOT = HERE / "docs" / "img" / "time_to_quality.png"


def plot(points: dict, labels: dict[str, str], path: Path) -> None:
    """One panel per brush: PSNR (dB) against seconds, a line per checkout through its budgets."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    brushes = sorted({brush for brush, _ in points})
    figure, axes = plt.subplots(1, len(brushes), figsize=(4 * len(brushes), 3.6), squeeze=False)
    for ax, brush in zip(axes[0], brushes):
        budgets = sorted(n for b, n in points if b == brush)
        for side, style in (("B", "o--"), ("A", "o-"), (COMPILED, "s:")):
            if side not in points[brush, budgets[0]]:
                continue
            xs = [points[brush, n][side]["wall"] for n in budgets]
            ys = [points[brush, n][side]["psnr"] for n in budgets]
            ax.plot(xs, ys, style, label=labels[side])
            if side == "A":
                for n, x, y in zip(budgets, xs, ys):
                    ax.annotate(str(n), (x, y), textcoords="offset points", xytext=(4, -10), fontsize=7)
        ax.set_title(brush)
        ax.set_xlabel("seconds, whole command")
        ax.set_ylabel("PSNR (dB)")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    figure.tight_layout()
    path.parent.mkdir(exist_ok=True)
    figure.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True, help="the other checkout (B): its src/ is imported")
    parser.add_argument("--base-name", default="B", help="what the docs call B (e.g. its date)")
    parser.add_argument("--photo", default="astronaut")
    parser.add_argument("--brushes", nargs="+", default=list(BRUSHES), choices=list(BRUSHES))
    parser.add_argument("--strokes", nargs="+", type=int, default=[200, 500, 1000, 2000, 5000])
    parser.add_argument("--repeats", type=int, default=1, help="runs of each checkout per point (the fastest counts)")
    parser.add_argument("--date", default=time.strftime("%Y-%m-%d"))
    args = parser.parse_args()
    points = {}
    with tempfile.TemporaryDirectory() as tmp:
        caches = {side: Path(tmp) / side.replace(",", "").replace(" ", "-") for side in ("A", "B", COMPILED)}
        sides = {"A": HERE / "src", "B": args.base.resolve() / "src", COMPILED: HERE / "src"}
        for side, src in sides.items():  # untimed: the caches a first run fills (matplotlib's fonts)
            os.environ.update(PYTHONPATH=str(src), XDG_CACHE_HOME=str(caches[side]))
            paint_once(args.photo, "tape", 20, Path(tmp) / "warm")
        os.environ.update(PYTHONPATH=str(HERE / "src"), XDG_CACHE_HOME=str(caches[COMPILED]))
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "nsp.engine"], check=True, stdout=subprocess.DEVNULL)  # make setup's compile
        compile_seconds = time.perf_counter() - start
        for brush in args.brushes:
            for strokes in args.strokes:
                best = {side: {"wall": float("inf")} for side in sides}
                for _ in range(args.repeats):
                    for side, src in sides.items():  # the subprocess imports this checkout's nsp, with its kernel cache
                        os.environ.update(PYTHONPATH=str(src), XDG_CACHE_HOME=str(caches[side]))
                        run = paint_once(args.photo, brush, strokes, Path(tmp) / "run")
                        if run["wall"] < best[side]["wall"]:
                            best[side] = {"wall": run["wall"], "psnr": run["metrics"]["psnr"]}
                points[brush, strokes] = best
                print(f"{brush} {strokes}: " + ", ".join(f"{side} {b['wall']:.1f} s {b['psnr']:.2f} dB" for side, b in best.items()),
                      flush=True)
    write(points, compile_seconds, args.base_name, args.photo, args.repeats, args.date)


def write(points: dict, compile_seconds: float, base_name: str, photo: str, repeats: int, date: str) -> None:
    """The curves (:func:`plot`) and the "Time to quality" section of docs/benchmarks.md, from
    ``points[brush, strokes][side] = {"wall": seconds, "psnr": dB}`` and the seconds of make setup's compile."""
    plot(points, {"A": "this commit, eager", "B": base_name, COMPILED: "this commit, compiled"}, PLOT)
    rows = ["| brush | strokes | wall A, compiled (s) | wall A, eager (s) | wall B (s) | compiled/B | PSNR A, compiled (dB) "
            "| PSNR A, eager (dB) | PSNR B (dB) |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for (brush, strokes), best in points.items():
        a, b, c = best["A"], best["B"], best[COMPILED]
        rows.append(f"| {brush} | {strokes:,} | {c['wall']:.1f} | {a['wall']:.1f} | {b['wall']:.1f} | {c['wall'] / b['wall']:.2f} "
                    f"| {c['psnr']:.2f} | {a['psnr']:.2f} | {b['psnr']:.2f} |")
    brushes = list(dict.fromkeys(brush for brush, _ in points))
    budgets = list(dict.fromkeys(strokes for _, strokes in points))
    command = (f"python benchmarks/quality.py --base B --base-name '{base_name}' --photo {photo} --repeats {repeats} "
               f"--brushes {' '.join(brushes)} --strokes {' '.join(map(str, budgets))}")
    write_section("Time to quality", "\n".join([
        f"`python -m nsp.paint image={photo} brush=… strokes=…` on its defaults, the whole command in a fresh "
        f"process (start-up, painting, files), A (this commit) and B ({base_name}) in turn, one at a time; the "
        f"fastest of {repeats} each, and the PSNR its metrics.json gives (final.png against the photo at a "
        "256-px long side). *Compiled*: A with the kernel cache `make setup` leaves (`python -m nsp.engine`, "
        f"{compile_seconds:.0f} s once, every brush, run first into a fresh cache): the painter's soft shading, "
        "forward and back, and the files' shading on compiled kernels. *Eager*: A with an empty cache, a machine "
        "where they are not (none compiled, or none could be). B with an empty cache.", "",
        f"Command: `{command}`  ", f"Machine: {machine()}, no GPU, nothing else running; {date}", "",
        "![PSNR against seconds per brush](img/time_to_quality.png)", "", *rows]))


if __name__ == "__main__":
    main()
