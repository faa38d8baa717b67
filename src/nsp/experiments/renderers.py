"""Does a better renderer paint better? (paper §3.2, §4.2). A painting experiment: one photo painted
with one renderer in the optimization loop, a checkpoint of a finished training sweep (each
renderer × brush × seed of ``experiment=renderer_comparison`` or ``renderer_ablation``) or the
analytic renderer (the soft vector engine, nothing trained), scored as the vector engine draws its
strokes (the true brush): PSNR and SSIM at a 256-px long side, and the painting's seconds.

``conf/paint/experiment/renderer_painting.yaml`` sweeps :func:`paint_with` over
:func:`trained_renderers` of the training sweep, the photos and the stroke budgets.
"""
from __future__ import annotations

import json
from pathlib import Path

from omegaconf import DictConfig, open_dict

from nsp.errors import BadInput

ANALYTIC = "analytic:"  # a swept renderer that is the analytic one, for the brush after the colon


def trained_renderers(sweep: str) -> str:
    """``${trained_renderers:DIR}``: every completed job's final checkpoint (``checkpoints/last.ckpt``,
    the model its test PSNR scores) in the training sweep ``DIR``, then ``analytic:BRUSH`` for each of
    their brushes, as one comma-separated sweep of quoted values."""
    jobs = sorted(path.parent.parent for path in Path(sweep).glob("*/checkpoints/last.ckpt")
                  if _metrics(path.parent.parent).get("status") == "completed")
    if not jobs:
        raise BadInput(f"task.sweep={sweep} holds no completed training job with checkpoints/last.ckpt; give the dir "
                       "of a finished `python -m nsp.train -m experiment=renderer_comparison` (or renderer_ablation)")
    brushes = dict.fromkeys(_metrics(job)["brush"] for job in jobs)
    values = [str(job / "checkpoints" / "last.ckpt") for job in jobs] + [ANALYTIC + brush for brush in brushes]
    if bad := [value for value in values if "'" in value or "\\" in value]:
        raise BadInput(f"task.sweep={sweep}: {bad[0]} has a quote or backslash in its path; move the sweep elsewhere")
    return ",".join(f"'{value}'" for value in values)


def paint_with(cfg: DictConfig, renderer: str, sweep: str) -> dict:
    """Paint ``cfg.image`` with ``cfg.strokes`` strokes through ``renderer`` (a checkpoint of the
    training sweep ``sweep``, as :func:`trained_renderers` lists them, or ``analytic:BRUSH``); writes
    the painting's files into ``cfg.output_dir``. Returns its metrics (``psnr``, ``ssim``,
    ``seconds``, …) with the renderer's ``renderer`` name, ``brush``, training ``seed`` and
    ``renderer_psnr`` (its test PSNR; none for the analytic renderer)."""
    from nsp.io.export import write_json
    from nsp.painter.run import paint
    from nsp.renderers.checkpoint import read_checkpoint

    if not renderer.startswith(ANALYTIC) and Path(sweep).resolve() not in Path(renderer).resolve().parents:
        raise BadInput(f"task.renderer={renderer} is not a checkpoint of task.sweep={sweep}; give analytic:BRUSH "
                       "or one of its jobs' checkpoints/last.ckpt")
    if renderer.startswith(ANALYTIC):
        brush, trained = renderer[len(ANALYTIC):], {"renderer": "analytic"}
    else:
        brush = read_checkpoint(renderer)["hyper_parameters"]["brush"]
        job = _metrics(Path(renderer).parent.parent)
        trained = {"renderer": job.get("renderer"), "seed": job.get("seed"), "renderer_psnr": job.get("test/psnr")}
    painting = cfg.copy()
    with open_dict(painting):
        painting.brush.name = brush
        painting.renderer.name = "analytic" if renderer.startswith(ANALYTIC) else "neural"
        painting.renderer.checkpoint = None if renderer.startswith(ANALYTIC) else renderer
        painting.task = None
    metrics = paint(painting) | {"brush": brush, **trained}
    write_json(Path(cfg.output_dir) / "metrics.json", metrics)
    return metrics


def _metrics(job: Path) -> dict:
    try:
        metrics = json.loads((job / "metrics.json").read_text())
    except (OSError, ValueError):
        return {}
    return metrics if isinstance(metrics, dict) else {}
