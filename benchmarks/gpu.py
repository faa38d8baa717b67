"""Everything the GPU issue measures, in one call of at most ``--budget`` seconds: 500- and
5000-stroke paintings of every brush (the command, end to end) beside the same host's CPU, the
vector engine at 128, 512 and 2048 px, renderer training steps at the paper's scale, and a 128-px
training run of dual and DCGAN-G for as long as it is given (its validation curve).

    python benchmarks/gpu.py                          # the GPU torch sees; writes the "On a GPU: …" sections
    python benchmarks/gpu.py --device cpu --smoke     # tiny, on the CPU: proves the script runs; writes nothing

The parts run in that order, each with its share of the budget and what the ones before left
(a row says what it could not measure). Each engine and training rate is the fastest of ``--repeats`` timed calls after
a warm-up, the device synchronized before each clock is read. A painting is ``python -m nsp.paint``
in a fresh process, timed from outside (start-up included), with the PSNR and the painting's own
time from its metrics.json; on a GPU it takes ``renderer.static`` (nothing read back a step) and
``schedule.static`` (each level's steps in one shape, replayed as a CUDA graph), and ``--compare``
brushes paint twice more: free steps (``schedule.static=false``, eager) and culling on the host too.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch
from omegaconf import OmegaConf

from nsp.brushes import BRUSHES
from nsp.engine import paint_canvas, render

sys.path.insert(0, str(Path(__file__).parent))
from doc import best_seconds, machine, write_section  # noqa: E402
from engine import CANVAS, strokes  # noqa: E402
from training import CONF, default_config  # noqa: E402

PARTS = ("paintings", "engine", "training", "study")
COMPARED = ("schedule.static=false", "renderer.static=false schedule.static=false")  # --compare brushes' other settings
UNCAPTURED = "could not be captured as a CUDA graph"  # what nsp.painter.steps logs when a step stays eager
SHARES = {"paintings": 0.35, "engine": 0.2, "training": 0.1, "study": 0.35}  # of the budget; what one leaves goes on
DENSE = 1 << 24  # floats of a dense batch: 256 strokes at 128 px, 16 at 512, 1 at 2048
SPENT = "not run: the budget was spent"


class Clock:
    """The call's deadline: ``budget`` seconds from now."""

    def __init__(self, budget: float):
        self.deadline = time.perf_counter() + budget

    def left(self) -> float:
        return self.deadline - time.perf_counter()


def synchronize(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def paint_once(device: str, brush: str, count: int, extra: list[str], timeout: float) -> str:
    """``python -m nsp.paint device=D brush=B strokes=N`` in a fresh process: its cells of a row."""
    with tempfile.TemporaryDirectory() as folder:
        run = Path(folder) / "run"
        line = [sys.executable, "-m", "nsp.paint", f"device={device}", f"brush={brush}", f"strokes={count}",
                "progress=false", f"hydra.run.dir={run}", *extra]
        start = time.perf_counter()
        try:
            done = subprocess.run(line, capture_output=True, text=True, timeout=max(1.0, timeout))
        except subprocess.TimeoutExpired:
            return f"over {timeout:.0f} s: stopped | | |"
        if done.returncode:
            print(done.stderr[-3000:], file=sys.stderr)
            return f"failed (exit {done.returncode}) | | |"
        seconds = time.perf_counter() - start
        metrics = json.loads((run / "metrics.json").read_text())
    said = done.stdout + done.stderr  # the run's log is on screen
    captured = "–" if device == "cpu" or "schedule.static=false" in extra else "no" if UNCAPTURED in said else "yes"
    return f"{seconds:.1f} s | {metrics['painting_seconds']:.1f} s | {metrics['psnr']:.2f} dB | {captured}"


def painting_rows(device: torch.device, brushes: list[str], counts: list[int], compare: list[str],
                  clock: Clock, extra: list[str]) -> list[str]:
    """Each brush at each stroke count on ``device`` (its defaults), the ``compare`` brushes at the
    most strokes in the :data:`COMPARED` settings, and each brush at the fewest on this host's CPU
    (the same settings: PSNRs that should agree)."""
    runs = [(device.type, name, count, "") for count in counts for name in brushes]
    runs += [(device.type, name, max(counts), setting) for setting in COMPARED for name in compare]
    runs += [("cpu", name, min(counts), "") for name in brushes] if device.type != "cpu" else []
    rows = ["| device | brush | strokes | settings | whole command | painting | PSNR | CUDA graph |",
            "|---|---|---:|---|---:|---:|---:|---|"]
    for where, name, count, setting in runs:
        cells = (paint_once(where, name, count, setting.split() + extra, clock.left()) if clock.left() > 0
                 else f"{SPENT} | | |")
        rows.append(f"| {where} | {name} | {count} | {setting or 'defaults'} | {cells} |")
        print(rows[-1], flush=True)
    return rows


def engine_rows(device: torch.device, sizes: list[int], repeats: int, canvas: int, clock: Clock) -> list[str]:
    """Strokes/s of each brush at each size: a batch rendered alone into a reused dense tensor, and
    ``canvas`` strokes (a tenth at 2048 px) painted in order onto one canvas, as ``nsp.render`` does."""
    rows = ["| brush | canvas | batch, each alone | strokes/s alone | painted in order | strokes/s in order |",
            "|---|---:|---:|---:|---:|---:|"]
    for name, brush in BRUSHES.items():
        many = strokes(name, canvas, True, device)
        for size in sizes:
            if clock.left() <= 0:
                rows.append(f"| {name} | {size} px | {SPENT} | | | |")
                continue
            batch = max(1, min(256, DENSE // (4 * size * size)))
            ordered = many[: canvas // 10 if size >= 2048 else canvas]
            out = torch.empty(batch, 4, size, size, device=device)
            alone = batch / best_seconds(lambda: (render(brush, many[:batch], size, out=out), synchronize(device)),
                                         repeats)
            painted = len(ordered) / best_seconds(lambda: (paint_canvas(brush, ordered, size, size),
                                                           synchronize(device)), repeats)
            rows.append(f"| {name} | {size} px | {batch} | {alone:,.0f} | {len(ordered):,} | {painted:,.0f} |")
            print(rows[-1], flush=True)
    return rows


def training_rows(device: torch.device, renderers: list[str], repeats: int, steps: int, clock: Clock) -> list[str]:
    """Strokes/s of drawing batches on the device and of training steps (forward, backward, Adam
    step) of each renderer at ``preset=paper`` (128 px, batch 64), watercolor: in float32, and with
    the forward and loss autocast to bfloat16 (what ``trainer.precision=bf16-mixed`` does)."""
    from nsp.training.data import StrokeData
    from nsp.training.module import RendererModule

    rows = ["| renderer | parameters | drawing the batches, strokes/s | training step, strokes/s | bf16-mixed step, "
            "strokes/s |", "|---|---:|---:|---:|---:|"]
    for renderer in renderers:
        if clock.left() <= 0:
            rows.append(f"| {renderer} | {SPENT} | | | |")
            continue
        cfg = default_config(f"renderer={renderer}", "brush=watercolor", "preset=paper")
        model = RendererModule(OmegaConf.to_container(cfg.renderer, resolve=True), "watercolor").to(device)
        optimizer = torch.optim.Adam(model.parameters(), cfg.model.optimizer.lr)
        data = StrokeData("watercolor", cfg.model.size, batch_size=cfg.data.batch_size, val_size=1,
                          render_on_device=True)
        data.setup("fit")
        x = [data.train_set[i].to(device) for i in range(steps)]
        drawn = [data.on_after_batch_transfer(batch, 0) for batch in x]

        def draw():
            for batch in x:
                data.on_after_batch_transfer(batch, 0)
            synchronize(device)

        def train(bf16: bool = False):
            for batch in drawn:
                with torch.autocast(device.type, dtype=torch.bfloat16, enabled=bf16):
                    loss, _, _ = model.loss(batch)
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
            synchronize(device)

        n = steps * cfg.data.batch_size
        params = sum(p.numel() for p in model.parameters())
        rates = [n / best_seconds(work, repeats) for work in (draw, train, lambda: train(True))]
        rows.append(f"| {renderer} | {params / 1e6:.2f} M | " + " | ".join(f"{rate:,.0f}" for rate in rates) + " |")
        print(rows[-1], flush=True)
    return rows


def study_rows(device: torch.device, renderers: list[str], seconds: float, clock: Clock, extra: list[str]) -> list[str]:
    """``python -m nsp.train preset=paper renderer=R brush=watercolor`` for ``seconds`` each
    (``trainer.max_time``), validated every epoch of 6,400 strokes: its validation PSNR by step, and
    the test PSNR it ends with."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    trainer = "trainer=gpu" if device.type == "cuda" else "trainer=default"
    rows = ["| renderer | seconds | steps | validation PSNR (dB) by step | test PSNR |", "|---|---:|---:|---|---:|"]
    for index, renderer in enumerate(renderers):
        given = min(seconds, clock.left() / (len(renderers) - index) - 30)  # 30: start-up, the last validation, the test
        if given <= 0:
            rows.append(f"| {renderer} | {SPENT} | | | |")
            continue
        with tempfile.TemporaryDirectory() as folder:
            run = Path(folder) / "run"
            line = [sys.executable, "-m", "nsp.train", trainer, "preset=paper", f"renderer={renderer}", "brush=watercolor",
                    f"trainer.max_time=00:00:{int(given) // 60:02d}:{int(given) % 60:02d}", "data.epoch_size=6400",
                    "trainer.enable_progress_bar=false", f"hydra.run.dir={run}", *extra]
            done = subprocess.run(line, capture_output=True, text=True)
            if done.returncode:
                print(done.stderr[-3000:], file=sys.stderr)
                rows.append(f"| {renderer} | {given:.0f} | failed (exit {done.returncode}) | | |")
                continue
            curve = [(e.step, e.value) for e in EventAccumulator(str(run)).Reload().Scalars("val/psnr")]
            test = json.loads((run / "metrics.json").read_text())["test/psnr"]
        picks = sorted({round(i * (len(curve) - 1) / 7) for i in range(8)}) if curve else []  # 8 points at most
        points = ", ".join(f"{curve[i][0]}: {curve[i][1]:.2f}" for i in picks)
        rows.append(f"| {renderer} | {given:.0f} | {curve[-1][0] if curve else 0} | {points} | {test:.2f} dB |")
        print(rows[-1], flush=True)
    return rows


SECTIONS = {  # each part's section of docs/benchmarks.md, and what its table shows
    "paintings": ("On a GPU: paintings",
                  "`python -m nsp.paint device=D brush=B strokes=N` on its other defaults (the astronaut), a fresh "
                  "process each, timed from outside (start-up included); *painting* and the PSNR from its metrics.json. "
                  "On the GPU its defaults read nothing back a step (`renderer.static`) and replay each level's step "
                  "as a CUDA graph (`schedule.static`; *CUDA graph* says whether it was captured); "
                  "`schedule.static=false` takes the free steps, eagerly, and `renderer.static=false` culls on the host. "
                  "The CPU rows are the same host's, the same day."),
    "engine": ("On a GPU: the vector engine",
               "The vector engine on the GPU, eager (its compiled kernels are the CPU's), moderate random strokes "
               "(`benchmarks/engine.py`'s): a batch each rendered alone into a reused dense tensor (16 M floats: 256 "
               f"strokes at 128 px, 16 at 512, 1 at 2048), and {CANVAS:,} ({CANVAS // 10:,} at 2048 px) painted in "
               "order onto one canvas, as `nsp.render` does. The fastest of several timed calls after a warm-up, the "
               "GPU synchronized."),
    "training": ("On a GPU: renderer training",
                 "Renderer training at `preset=paper` (128 px, batch 64, the paper's layers), watercolor: the batches "
                 "drawn by the engine on the GPU (`data.render_on_device`, uniform random strokes, as training draws "
                 "them), and training steps (forward, backward, Adam step) on drawn batches, in float32 and with the "
                 "forward and loss autocast to bfloat16 (`trainer.precision=bf16-mixed`'s speed; its accuracy is not "
                 "measured here). The fastest of several timed calls of `--steps` batches."),
    "study": ("On a GPU: a 128-px training run",
              "`python -m nsp.train trainer=gpu preset=paper renderer=R brush=watercolor data.epoch_size=6400` for a "
              "fixed time (`trainer.max_time`), validated every 100 steps: the start of the paper's study, its "
              "validation PSNR by step and the test PSNR it ended with."),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS), help="what is measured")
    parser.add_argument("--device", default="cuda", help="cuda (default) or cpu, with --smoke")
    parser.add_argument("--budget", type=float, default=470, help="seconds the whole call may take")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per rate")
    parser.add_argument("--strokes", type=int, nargs="+", default=[500, 5000], help="strokes of the paintings")
    parser.add_argument("--brushes", nargs="+", default=list(BRUSHES), help="the brushes painted with")
    parser.add_argument("--compare", nargs="+", default=["watercolor"],
                        help="brushes painted with free steps and culling on the host too")
    parser.add_argument("--steps", type=int, default=10, help="training batches per timed call")
    parser.add_argument("--study-seconds", type=float, default=90, help="seconds of each 128-px training run")
    parser.add_argument("--smoke", action="store_true", help="tiny settings, nothing written: does the script run?")
    args = parser.parse_args()
    device = torch.device(args.device)
    if device.type == "cuda" and not torch.cuda.is_available():
        sys.exit("benchmarks/gpu.py: torch sees no GPU (--device cpu --smoke checks the script)")
    total = Clock(args.budget)
    tiny = ["work_size=64"] if args.smoke else []  # a smoke test's paintings and runs: seconds, not minutes
    small = ["data.epoch_size=128", "data.val_size=64", "data.test_size=64", "trainer.max_steps=4"] if args.smoke else []
    measure = {
        "paintings": lambda clock: painting_rows(device, args.brushes, args.strokes, args.compare, clock, tiny),
        "engine": lambda clock: engine_rows(device, [128] if args.smoke else [128, 512, 2048], args.repeats,
                                            100 if args.smoke else CANVAS, clock),
        "training": lambda clock: training_rows(device, ["dcgan", "dual"], args.repeats, args.steps, clock),
        "study": lambda clock: study_rows(device, ["dual", "dcgan"], args.study_seconds, clock, small)}
    command = " ".join(["python", "benchmarks/gpu.py", *sys.argv[1:]])
    for index, part in enumerate(args.parts):
        rows = measure[part](Clock(total.left() * SHARES[part] / sum(SHARES[p] for p in args.parts[index:])))
        if device.type == "cuda" and not args.smoke:
            title, text = SECTIONS[part]
            write_section(title, "\n".join([text, "", f"Command: `{command}`  ",
                                            f"Machine: {machine()}; {time.strftime('%Y-%m-%d')}", "", *rows]))
    print(f"benchmarks/gpu.py: {', '.join(args.parts)} in {args.budget - total.left():.0f} s of {args.budget:.0f}")


if __name__ == "__main__":
    main()
