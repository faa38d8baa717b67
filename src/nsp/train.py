"""``python -m nsp.train renderer=R brush=B``: train a neural stroke renderer (paper §3.2).

Config: ``conf/train/train.yaml``; results in the Hydra run dir (``metrics.json``, ``checkpoints/``,
``tensorboard/``, ``train.log``). Lightning and torch are imported only once the command line has
been read.
"""
from __future__ import annotations

import logging
import sys
from pathlib import Path

from omegaconf import DictConfig

from nsp.cli import INTERRUPTED, Usage, chosen, command, run_job

log = logging.getLogger("nsp.train")  # Hydra sends it to the console and train.log

USAGE = Usage(
    summary="Train a neural stroke renderer on strokes the vector engine draws; writes metrics.json, "
            "checkpoints/ (best.ckpt, last.ckpt) and TensorBoard logs into the run dir.",
    examples=(
        "  # dual on watercolor, the CPU preset (minutes)",
        "renderer=unet brush=oilpaint",
        "preset=paper trainer=gpu  # the paper's scale, on one GPU",
        "-m experiment=renderer_comparison  # a saved study; then python -m nsp.report",
    ),
    keys={
        "trainer.max_steps=N": "how long to train",
        "model.size=PX": "the renderer's output side: 32, 64 or 128",
        "model.channel_mult=X": "network width, × the paper's",
        "data.batch_size=N": "strokes per step",
        "ckpt_path=PATH": "resume from a checkpoint (its own dir: continues in place)",
        "seed=N": "initialisation and training strokes",
        "hydra.run.dir=DIR": "where the files go (outputs/train/<time>_<renderer>_<brush>)",
    },
    groups={
        "renderer": "the network",
        "brush": "the brush whose strokes it learns",
        "preset": "the scale: cpu (minutes) or paper",
        "trainer": "where it runs",
        "lr_schedule": "the learning-rate schedule",
        "experiment": "a saved study (run with -m)",
    },
)


def starting(renderer: str, brush: str, preset: str) -> str:
    """What a run says first, on screen before Lightning and torch load, and in train.log."""
    return f"training renderer {renderer} on {brush} strokes, preset {preset}…"


def opening(argv: list[str]) -> str:
    """The first line of a run, from the command line alone."""
    choices = [chosen(argv, "train", key) for key in ("renderer", "brush", "preset")]
    return f"starting {' '.join(['python -m nsp.train', *argv])}…" if None in choices else starting(*choices)


def main(cfg: DictConfig) -> float | None:
    from hydra.core.hydra_config import HydraConfig

    from nsp.training import train

    choices = HydraConfig.get().runtime.choices
    log.info(starting(choices.renderer, choices.brush, choices.preset))  # shown once: the opening line was this
    try:
        metrics = run_job(cfg, train)  # a bad value the schema cannot type (e.g. model.size=48): one line, no traceback
    except KeyboardInterrupt:
        last = Path(cfg.output_dir) / "checkpoints" / "last.ckpt"
        print(f"interrupted: resume with ckpt_path={last} hydra.run.dir={cfg.output_dir}" if last.is_file() else
              "interrupted before training began; nothing saved", file=sys.stderr)
        sys.exit(INTERRUPTED)
    if metrics is None:  # a failed job of a sweep, recorded in its dir
        return None
    saved = ", ".join(p.name for name in ("best.ckpt", "last.ckpt") if (p := Path(cfg.output_dir) / "checkpoints" / name).is_file())
    log.info(f"trained {metrics['renderer']} on {metrics['brush']}: {metrics['steps']} steps in {metrics['seconds']:.0f} s, "
             f"test PSNR {metrics['test/psnr']:.2f} dB (validation {metrics['val/psnr']:.2f}): {cfg.output_dir} "
             f"(metrics.json, checkpoints/{saved})")
    return metrics["val/psnr"]


def schema() -> object:
    """Every key a training config can have (registers ``train_schema`` and its parts)."""
    from nsp.training.schema import key_tree, register_configs

    register_configs()
    return key_tree()


def cli() -> None:
    """The command line: ``python -m nsp.train``."""
    command("train", main, schema, USAGE, opening=opening,
            text=("ckpt_path", "brush.texture", "hydra.run.dir", "hydra.sweep.dir"))


if __name__ == "__main__":
    cli()
