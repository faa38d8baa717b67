"""Does a better renderer paint better? (paper §3.2, §4.2). A painting experiment: one photo painted
through one renderer, a checkpoint of a finished training sweep or the analytic one, and scored as
the vector engine draws its strokes. ``conf/paint/experiment/renderer_painting.yaml`` sweeps
:func:`paint_with` over :func:`nsp.config.trained_renderers`, the photos and the stroke budgets.
"""
from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig, open_dict

from nsp.config import ANALYTIC, job_metrics, trained_jobs
from nsp.errors import BadInput


def paint_with(cfg: DictConfig, renderer: str, sweep: str) -> dict:
    """Paint ``cfg.image`` through ``renderer`` (a checkpoint of the training sweep ``sweep``, or
    ``analytic:BRUSH[:SEED]``) into ``cfg.output_dir``; returns its metrics with the renderer's name,
    ``brush``, ``seed`` and ``renderer_psnr`` (its test PSNR; none for the analytic one).

    Fair by construction: the analytic renderer optimizes its blocks at the networks' resolution (their
    size S as ``renderer.block_size``), and the painter's seed is the checkpoint's training seed (the
    analytic renderer's ``SEED``, else ``cfg.seed``), so every renderer has a spread over seeds."""
    from nsp.files import write_json
    from nsp.painting.run import paint
    from nsp.painting.schema import paint_settings
    from nsp.renderers.checkpoint import read_checkpoint

    analytic = renderer.startswith(ANALYTIC)
    if not analytic and Path(sweep).resolve() not in Path(renderer).resolve().parents:
        raise BadInput(f"task.renderer={renderer} is not a checkpoint of task.sweep={sweep}; give analytic:BRUSH[:SEED] "
                       "or one of its jobs' checkpoints/last.ckpt")
    if analytic:
        brush, _, seed = renderer[len(ANALYTIC):].partition(":")
        if seed and not seed.isdigit():
            raise BadInput(f"task.renderer={renderer}: its seed {seed!r} is not a whole number; give analytic:BRUSH:SEED")
        trained = {"renderer": "analytic", "seed": int(seed) if seed else cfg.seed}
        sizes = sorted({job_metrics(job).get("size") for job in trained_jobs(sweep)}, key=str)
        if len(sizes) != 1 or not isinstance(sizes[0], int):
            raise BadInput(f"task.sweep={sweep} holds networks of sizes {sizes}; the analytic renderer paints at one, "
                           "give a sweep of one model.size")
    else:
        brush = read_checkpoint(renderer)["hyper_parameters"]["brush"]
        job = job_metrics(Path(renderer).parent.parent)
        trained = {"renderer": job.get("renderer"), "seed": job.get("seed", cfg.seed), "renderer_psnr": job.get("test/psnr")}
    painting = cfg.copy()
    with open_dict(painting):
        painting.brush.name = brush
        painting.renderer.name = "analytic" if analytic else "neural"
        painting.renderer.checkpoint = None if analytic else renderer
        painting.seed = trained["seed"]
        if analytic:
            painting.renderer.block_size = sizes[0]
        painting.task = None
    metrics = paint(paint_settings(painting)) | {"brush": brush, **trained}
    write_json(Path(cfg.output_dir) / "metrics.json", metrics)
    return metrics
