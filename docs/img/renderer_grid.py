"""The paper's visual comparison of renderers: the same test strokes drawn by the vector engine (the
truth) and by each trained renderer, foreground and alpha side by side, a block per brush.

    python docs/img/renderer_grid.py OUT.png SWEEP [SWEEP ...] [--strokes 6] [--seed 0]

SWEEP: finished training sweeps (experiment=renderer_comparison, renderer_ablation, their _64
versions); each renderer × brush is shown by its job of training seed ``--seed``. The strokes are the
first of the test set every run of that size scores (StrokeData's test strokes: seed 0), so the grid
shows what the test PSNR measures. docs/img/renderer_grid_32.png:

    python -m nsp.train -m experiment=renderer_comparison hydra/launcher=joblib hydra.sweep.dir=SWEEP32
    python docs/img/renderer_grid.py docs/img/renderer_grid_32.png SWEEP32
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import torch  # noqa: E402

from nsp.brushes import get_brush  # noqa: E402
from nsp.config import job_metrics  # noqa: E402
from nsp.renderers.checkpoint import load_renderer  # noqa: E402
from nsp.reporting.tables import renderer_order  # noqa: E402
from nsp.training.data import draw, generator  # noqa: E402

TEST_STREAM = 2  # StrokeData draws its test strokes from generator(test_seed, 2)


def renderers(sweeps: list[Path], seed: int) -> dict[str, dict[str, Path]]:
    """brush -> renderer -> the final checkpoint of its completed job with training seed ``seed``."""
    found: dict[str, dict[str, Path]] = {}
    for sweep in sweeps:
        for last in sorted(sweep.glob("*/checkpoints/last.ckpt")):
            metrics = job_metrics(last.parents[1])
            if metrics.get("status") == "completed" and metrics.get("seed") == seed:
                found.setdefault(metrics["brush"], {})[metrics["renderer"]] = last
    return {brush: dict(sorted(by.items(), key=lambda item: renderer_order(item[0]))) for brush, by in found.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("sweeps", type=Path, nargs="+")
    parser.add_argument("--strokes", type=int, default=6)
    parser.add_argument("--seed", type=int, default=0, help="the training seed whose job shows each renderer")
    args = parser.parse_args()
    found = renderers(args.sweeps, args.seed)
    rows = [(brush, name, path) for brush, by in found.items() for name, path in [("vector engine", None), *by.items()]]
    fig, axes = plt.subplots(len(rows), 2 * args.strokes, figsize=(1.1 * 2 * args.strokes, 1.2 * len(rows)), squeeze=False)
    drawn: dict[str, tuple] = {}
    for row, (brush, name, path) in zip(axes, rows):
        if path is None:
            network, size = None, load_renderer(next(iter(found[brush].values())))[2]
        else:
            network, _, size = load_renderer(path)
        if brush not in drawn:  # the same strokes for every renderer of the brush
            drawn[brush] = draw(get_brush(brush), args.strokes, size, generator(0, TEST_STREAM))
        x, fg, alpha = drawn[brush]
        if network is not None:
            with torch.no_grad():
                fg, alpha = network(x)
        for i in range(args.strokes):
            for ax, image, cmap in ((row[2 * i], fg[i].clamp(0, 1).permute(1, 2, 0), None), (row[2 * i + 1], alpha[i, 0], "gray")):
                ax.imshow(image.numpy(), cmap=cmap, vmin=0, vmax=1, interpolation="nearest")
                ax.set_xticks([])
                ax.set_yticks([])
        row[0].set_ylabel(f"{brush}\n{name}", rotation=0, ha="right", va="center", fontsize=8)
    for i in range(args.strokes):
        axes[0][2 * i].set_title(f"stroke {i + 1}", fontsize=7, loc="left")
    fig.suptitle(f"The same test strokes ({size} px): foreground, alpha; the vector engine, then each trained renderer", fontsize=9)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}: {len(rows)} rows, {args.strokes} strokes")


if __name__ == "__main__":
    main()
