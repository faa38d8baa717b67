"""The CUDA rows: the vector engine at 128, 512 and 2048 px, 5000-stroke paintings (the command, end
to end) and renderer training steps at the paper's scale, on the GPU torch sees.

    python benchmarks/gpu.py [--parts engine training paintings] [--repeats 5] [--strokes 5000] [--brushes ...]
        [--static true false]

Each engine and training rate is the fastest of ``--repeats`` timed calls after a warm-up, the GPU
synchronized before each clock is read. A painting is ``python -m nsp.paint device=cuda`` in a fresh
process, timed from outside (start-up included), with the PSNR and the painting's own time from its
metrics.json. Prints markdown tables and writes each part's as its "On a GPU: …" section of
docs/benchmarks.md.
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

SIZES = (128, 512, 2048)
PARTS = ("engine", "training", "paintings")
DENSE = 1 << 24  # floats of a dense batch: 256 strokes at 128 px, 16 at 512, 1 at 2048


def engine_rows(device: torch.device, repeats: int) -> list[str]:
    """Strokes/s of each brush at each size: a batch rendered alone into a reused dense tensor, and
    6000 painted in order onto one canvas (what ``nsp.render`` does)."""
    rows = ["| brush | canvas | batch, each alone | strokes/s alone | 6,000 on a canvas, strokes/s |", "|---|---:|---:|---:|---:|"]
    sync = torch.cuda.synchronize
    for name, brush in BRUSHES.items():
        many = strokes(name, CANVAS, True, device)
        for size in SIZES:
            batch = max(1, min(256, DENSE // (4 * size * size)))
            out = torch.empty(batch, 4, size, size, device=device)
            alone = batch / best_seconds(lambda: (render(brush, many[:batch], size, out=out), sync()), repeats)
            canvas = CANVAS / best_seconds(lambda: (paint_canvas(brush, many, size, size), sync()), repeats)
            rows.append(f"| {name} | {size} px | {batch} | {alone:,.0f} | {canvas:,.0f} |")
            print(rows[-1], flush=True)
    return rows


def painting_rows(brushes: list[str], count: int, timeout: float, static: list[str]) -> list[str]:
    """``python -m nsp.paint device=cuda strokes=count brush=B renderer.static=S`` per brush and S
    (true: every stroke on its whole block, nothing read back a step; false: culled on the host), a
    fresh process each, stopped after ``timeout`` seconds."""
    rows = ["| brush | strokes | renderer.static | whole command | painting | PSNR |", "|---|---:|---|---:|---:|---:|"]
    for name in brushes:
        for choice in static:
            with tempfile.TemporaryDirectory() as folder:
                run = Path(folder) / "run"
                line = [sys.executable, "-m", "nsp.paint", "device=cuda", f"brush={name}", f"strokes={count}",
                        f"renderer.static={choice}", "progress=false", f"hydra.run.dir={run}"]
                start = time.perf_counter()
                try:
                    done = subprocess.run(line, capture_output=True, text=True, timeout=timeout)
                except subprocess.TimeoutExpired:
                    rows.append(f"| {name} | {count} | {choice} | over {timeout} s: stopped | | |")
                    continue
                seconds = time.perf_counter() - start
                if done.returncode:
                    print(done.stderr[-3000:], file=sys.stderr)
                    rows.append(f"| {name} | {count} | {choice} | failed (exit {done.returncode}) | | |")
                    continue
                metrics = json.loads((run / "metrics.json").read_text())
            rows.append(f"| {name} | {count} | {choice} | {seconds:.1f} s | {metrics['painting_seconds']:.1f} s "
                        f"| {metrics['psnr']:.2f} dB |")
            print(rows[-1], flush=True)
    return rows


def training_rows(device: torch.device, repeats: int, steps: int) -> list[str]:
    """Strokes/s of training steps (forward, backward, Adam step) of each renderer at ``preset=paper``
    (128 px, batch 64, each batch drawn on the GPU), watercolor, and of the drawing alone."""
    from nsp.training.data import StrokeData
    from nsp.training.module import RendererModule

    sync = torch.cuda.synchronize
    rows = ["| renderer | parameters | drawing the batches, strokes/s | training step, strokes/s |", "|---|---:|---:|---:|"]
    for renderer in sorted(p.stem for p in (CONF / "renderer").glob("*.yaml")):
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
            sync()

        def train():
            for batch in drawn:
                loss, _, _ = model.loss(batch)
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
            sync()

        n = steps * cfg.data.batch_size
        params = sum(p.numel() for p in model.parameters())
        rows.append(f"| {renderer} | {params / 1e6:.2f} M | {n / best_seconds(draw, repeats):,.0f} "
                    f"| {n / best_seconds(train, repeats):,.0f} |")
        print(rows[-1], flush=True)
    return rows


SECTIONS = {  # each part's section of docs/benchmarks.md, and what its table shows
    "engine": ("On a GPU: the vector engine",
               "The vector engine on the GPU, eager (its compiled kernels are the CPU's), moderate random strokes "
               "(`benchmarks/engine.py`'s): a batch each rendered alone into a reused dense tensor (16 M floats: 256 "
               f"strokes at 128 px, 16 at 512, 1 at 2048), and {CANVAS:,} painted in order onto one canvas, as "
               "`nsp.render` does. The fastest of several timed calls after a warm-up, the GPU synchronized."),
    "training": ("On a GPU: renderer training",
                 "Renderer training at `preset=paper` (128 px, batch 64, the paper's layers), watercolor: the batches "
                 "drawn by the engine on the GPU (`data.render_on_device`, uniform random strokes, as training draws "
                 "them), and training steps (forward, backward, Adam step) on drawn batches. The fastest of several "
                 "timed calls of `--steps` batches."),
    "paintings": ("On a GPU: paintings",
                  "`python -m nsp.paint device=cuda brush=B strokes=N` on its other defaults (the astronaut), a fresh "
                  "process each, timed from outside (start-up included); *painting* and the PSNR from its metrics.json."),
}


def write(part: str, rows: list[str], command: str, machine: str, date: str) -> None:
    """Write one part's table as its section of docs/benchmarks.md."""
    title, text = SECTIONS[part]
    write_section(title, "\n".join([text, "", f"Command: `{command}`  ", f"Machine: {machine}; {date}", "", *rows]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS), help="what is measured")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per rate")
    parser.add_argument("--strokes", type=int, default=5000, help="strokes of each painting")
    parser.add_argument("--brushes", nargs="+", default=["watercolor", "oilpaint", "markerpen", "tape"],
                        help="the brushes painted with")
    parser.add_argument("--timeout", type=float, default=300, help="seconds a painting may take")
    parser.add_argument("--static", nargs="+", default=["true", "false"], choices=["true", "false"],
                        help="the painter's renderer.static settings painted with")
    parser.add_argument("--steps", type=int, default=10, help="training batches per timed call")
    args = parser.parse_args()
    if not torch.cuda.is_available():
        sys.exit("benchmarks/gpu.py: torch sees no GPU")
    device = torch.device("cuda")
    measure = {"engine": lambda: engine_rows(device, args.repeats),
               "training": lambda: training_rows(device, args.repeats, args.steps),
               "paintings": lambda: painting_rows(args.brushes, args.strokes, args.timeout, args.static)}
    command = " ".join(["python", "benchmarks/gpu.py", *sys.argv[1:]])
    for part in args.parts:
        write(part, measure[part](), command, machine(), time.strftime("%Y-%m-%d"))


if __name__ == "__main__":
    main()
