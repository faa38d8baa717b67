"""Renderer training on CPU: datamodule strokes/s (the vector engine drawing training batches) next to
training-step strokes/s (forward, backward and Adam step of each renderer), at the default preset.

Data must not be the bottleneck: each brush's data rate should exceed the step rate of the renderers.
Prints markdown tables and writes them as the "Renderer training" section of docs/benchmarks.md.

    python benchmarks/training.py [--threads N] [--repeats R] [--steps K]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from nsp.brushes import BRUSHES
from nsp.training.data import StrokeData
from nsp.training.module import RendererModule
from nsp.training.schema import register_configs

sys.path.insert(0, str(Path(__file__).parent))
from doc import best_seconds, machine, write_section  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CONF = ROOT / "conf" / "train"


def best_rate(fn, strokes: int, repeats: int) -> float:
    """Strokes/s of the fastest of ``repeats`` timed calls."""
    return strokes / best_seconds(fn, repeats)


def default_config(*overrides: str):
    register_configs()
    with initialize_config_dir(str(CONF), version_base="1.3"):
        return compose("train", overrides=list(overrides))


def data_rate(brush: str, steps: int, repeats: int) -> float:
    cfg = default_config(f"brush={brush}")
    data = StrokeData(brush, cfg.model.size, batch_size=cfg.data.batch_size, val_size=1)
    data.setup("fit")
    loader = data.train_dataloader()

    batches = 4 * steps  # long enough that the loader's prefetched batches do not count

    def draw():
        for _, x in zip(range(batches), loader):
            data.on_after_batch_transfer(x, 0)  # renders here only with data.render_on_device

    return best_rate(draw, batches * cfg.data.batch_size, repeats)


def step_rate(renderer: str, brush: str, steps: int, repeats: int) -> tuple[float, int]:
    """Strokes/s of training steps on one pre-drawn batch, and the renderer's parameter count."""
    cfg = default_config(f"renderer={renderer}", f"brush={brush}")
    model = RendererModule(OmegaConf.to_container(cfg.renderer, resolve=True), brush)
    optimizer = torch.optim.Adam(model.parameters(), cfg.model.optimizer.lr)
    data = StrokeData(brush, cfg.model.size, batch_size=cfg.data.batch_size, val_size=1)
    data.setup("fit")
    batch = data.on_after_batch_transfer(data.train_set[0], 0)

    def train():
        for _ in range(steps):
            loss, _, _ = model.loss(batch)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()

    return best_rate(train, steps * cfg.data.batch_size, repeats), sum(p.numel() for p in model.parameters())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=None, help="training threads; default: the preset's")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--steps", type=int, default=10, help="batches per timed call")
    args = parser.parse_args()
    cfg = default_config()
    torch.set_num_threads(args.threads or cfg.threads or torch.get_num_threads())
    renderers = sorted(p.stem for p in (CONF / "renderer").glob("*.yaml"))

    data_rows = ["| brush | datamodule strokes/s |", "|---|---:|"]
    for brush in BRUSHES:
        data_rows.append(f"| {brush} | {data_rate(brush, args.steps, args.repeats):.0f} |")
        print(data_rows[-1], flush=True)
    step_rows = ["| renderer | parameters | training-step strokes/s |", "|---|---:|---:|"]
    for renderer in renderers:
        rate, params = step_rate(renderer, "watercolor", args.steps, args.repeats)
        step_rows.append(f"| {renderer} | {params / 1e6:.2f} M | {rate:.0f} |")
        print(step_rows[-1], flush=True)

    command = " ".join(["python", "benchmarks/training.py", *sys.argv[1:]])
    write_section("Renderer training", "\n".join([
        f"Default preset: {cfg.model.size} px, channel multiplier {cfg.model.channel_mult}, batch {cfg.data.batch_size}, "
        f"{cfg.data.num_workers} loader process(es). Datamodule: training batches sampled and drawn (antialiased) by "
        "the vector engine in the loader, as `python -m nsp.train` does; training step: forward, backward and Adam step "
        "on a watercolor batch, in the training process. Rates are the best of several timed runs.",
        "",
        f"Command: `{command}`  ",
        f"Machine: {machine()}; {time.strftime('%Y-%m-%d')}",
        "",
        *data_rows,
        "",
        *step_rows,
    ]))


if __name__ == "__main__":
    main()
