"""Tables of a multirun: a row per job (CSV; markdown without the columns every job shares) and, for
renderer sweeps, the renderer × brush pivot beside the paper's numbers, dual's margin over every other
renderer and, for learning-rate studies, the rate each renderer gets."""
from __future__ import annotations

import csv
import io
import math
import statistics
from dataclasses import dataclass
from numbers import Number

from nsp.reporting.collect import FAILED, Job, swept_keys

# Paper Table 1 (128 px, mean PSNR of foreground and alpha, dB); Fig. 9 gives curves, no numbers.
PAPER_PSNR = {
    ("dual_raster", "oilpaint"): 24.015, ("dual_shading", "oilpaint"): 26.048, ("dual", "oilpaint"): 26.982,
    ("dual_raster", "watercolor"): 25.769, ("dual_shading", "watercolor"): 29.045, ("dual", "watercolor"): 31.389,
}
HEADLINES = ("test/psnr", "val/psnr", "psnr")  # the metric a table reports: the first any job recorded
LR = "model.optimizer.lr"
PANEL = "brush"  # a pivot's columns, a plot's panels
SEED = "seed"  # repeats of one setting: pooled into mean ± std
DUAL = "dual"
ANALYTIC = "analytic"
RENDERERS = ("dcgan", "pxlshuffle", "unet", "dual_raster", "dual_shading", "dual_silhouette", "dual", ANALYTIC)  # the paper's order, the untrained last
STUDY_RENDERER = "task.renderer"  # experiment=renderer_painting's swept renderer: a checkpoint, or analytic:BRUSH
# How report.md writes a metric, by a word of its name (``val/psnr_fg``: psnr); other fractions .3f.
FORMATS = {"psnr": ".2f", "ssim": ".4f", "iou": ".3f", "seconds": ".1f", "lr": "g"}


@dataclass
class Stat:
    """A metric over the completed jobs of one setting (its seeds), written ``mean ± std`` (sample std)."""

    values: list[float]

    @property
    def mean(self) -> float:
        return statistics.fmean(self.values)

    @property
    def std(self) -> float:
        return statistics.stdev(self.values) if len(self.values) > 1 else 0.0

    def __format__(self, spec: str) -> str:
        """Mean and std in ``spec`` (default ``.2f``), the mean alone for a single value."""
        spec = spec or ".2f"
        return f"{self.mean:{spec}} ± {self.std:{spec}}" if len(self.values) > 1 else format(self.mean, spec)


def choices(jobs: list[Job], key: str) -> list:
    """The values of ``key`` the jobs ran with, in first-seen order; renderers in :data:`RENDERERS`' order
    (a study's folder may hold jobs of two sweeps, each numbered from 0)."""
    values = list(dict.fromkeys(job.choice(key) for job in jobs))
    return sorted(values, key=lambda name: renderer_order(str(name))) if key == "renderer" else values


def metric_keys(jobs: list[Job]) -> list[str]:
    """Numeric metrics any job recorded, in first-seen order; text (the brush's name, the status) has
    its own columns, and swept values theirs (``seed``, ``lr`` of ``model.optimizer.lr``)."""
    swept = {key.rsplit(".", 1)[-1] for key in swept_keys(jobs)}
    keys = dict.fromkeys(key for job in jobs for key, value in job.metrics.items()
                         if isinstance(value, Number) and not isinstance(value, bool))
    return [key for key in keys if key not in swept]


def job_rows(jobs: list[Job]) -> tuple[list[str], list[list]]:
    """Header and rows: job number, swept choices, status, final metrics (None where absent)."""
    swept, metrics = swept_keys(jobs), metric_keys(jobs)
    header = ["job", *swept, "status", *metrics]
    rows = [[job.num, *(job.overrides.get(k) for k in swept), job.status, *(job.metrics.get(k) for k in metrics)] for job in jobs]
    return header, rows


def shown_jobs(jobs: list[Job]) -> tuple[list[str], list[list], dict[str, str]]:
    """The job table as report.md shows it, each metric in its format, less a status every job shares
    and, given two jobs or more, a metric every job shares; and those metrics (name -> value, for the
    "Every job" line) but ones an override names already (``seed``, ``steps`` of ``trainer.max_steps``)."""
    header, rows = job_rows(jobs)
    metrics, overridden = set(metric_keys(jobs)), {key.rsplit(".", 1)[-1] for job in jobs for key in job.overrides}
    overridden |= {metric for metric in metrics for job in jobs for key, value in job.overrides.items()  # steps of max_steps
                   if key.endswith(metric) and str(job.metrics.get(metric)) == str(value)}
    shared, kept = {}, []
    for i, name in enumerate(header):
        values = {row[i] for row in rows}
        if len(values) == 1 and (name == "status" or (name in metrics and len(rows) > 1)):
            if name in metrics and name not in overridden:
                shared[name] = number(name, values.pop())
            continue
        kept.append(i)
    return [header[i] for i in kept], [[number(header[i], row[i]) for i in kept] for row in rows], shared


def number(key: str, value):
    """``value`` of metric ``key`` as report.md writes it (:data:`FORMATS`); text, None and whole
    numbers of a metric with no format as they are."""
    if not isinstance(value, Number) or isinstance(value, bool):
        return value
    spec = next((FORMATS[word] for word in key.rsplit("/", 1)[-1].split("_") if word in FORMATS), None)
    if spec is None:
        return value if isinstance(value, int) else f"{value:.3f}"
    return format(value, spec)


def headline(jobs: list[Job]) -> str | None:
    """The metric a study reports: the validation score where it chooses a learning rate (the choice
    must not see the test strokes), else the test score where jobs have one."""
    recorded = {key for job in jobs for key in job.metrics}
    if LR in swept_keys(jobs) and "val/psnr" in recorded:
        return "val/psnr"
    return next((key for key in HEADLINES if key in recorded), None)


def group_keys(jobs: list[Job]) -> list[str]:
    """Swept keys that tell settings apart: all but the seed (pooled) and the brush (columns, panels)."""
    return [key for key in swept_keys(jobs) if key not in (SEED, PANEL)]


def label(job: Job, keys: list[str]) -> str:
    """``key=value`` of ``keys`` (the last part of a dotted key), e.g. ``renderer=dual lr=0.001``."""
    return " ".join(f"{key.rsplit('.', 1)[-1]}={job.choice(key)}" for key in keys)


def score(job: Job, metric: str) -> float | None:
    """``metric`` of a completed job as a float; None when it did not complete or has no such number."""
    value = job.metrics.get(metric)
    usable = job.status == "completed" and isinstance(value, Number) and not isinstance(value, bool)
    return float(value) if usable else None


def stat(jobs: list[Job], metric: str) -> Stat | None:
    """``metric`` over the completed jobs among ``jobs``; None when none completed."""
    values = [value for value in (score(job, metric) for job in jobs) if value is not None]
    return Stat(values) if values else None


def is_renderer_sweep(jobs: list[Job]) -> bool:
    return "renderer" in swept_keys(jobs) and headline(jobs) in ("test/psnr", "val/psnr")


def pivot(jobs: list[Job]) -> tuple[list[str], list[list]]:
    """The study's table: a row per setting (renderer, lr, …), a column per brush, each cell the
    headline metric as mean ± std over seeds (else ``failed`` where a job failed, or the jobs' status:
    ``not run``, a sweep to resume), the paper's figure beside a brush it has any for, and each row's lr."""
    metric, keys, brushes = headline(jobs), group_keys(jobs), choices(jobs, PANEL)
    settings = list(dict.fromkeys(tuple(job.choice(k) for k in keys) for job in jobs))
    if "renderer" in keys:  # as choices() orders them
        settings.sort(key=lambda setting: renderer_order(str(setting[keys.index("renderer")])))
    with_paper = [b for b in brushes if any((job.choice("renderer"), b) in PAPER_PSNR for job in jobs)]
    show_lr = LR not in keys and any("lr" in job.metrics for job in jobs)
    header = [*keys, *(["lr"] if show_lr else [])]
    for brush in brushes:
        header += [str(brush)] + ([f"{brush} (paper)"] if brush in with_paper else [])
    rows = []
    for setting in settings:
        same = [job for job in jobs if tuple(job.choice(k) for k in keys) == setting]
        row: list = list(setting)
        if show_lr:
            row.append(", ".join(dict.fromkeys(str(number("lr", job.metrics["lr"])) for job in same if "lr" in job.metrics)) or None)
        for brush in brushes:
            cell = [job for job in same if job.choice(PANEL) == brush]
            score, statuses = stat(cell, metric), {job.status for job in cell}
            row.append(f"{score}" if score else FAILED if FAILED in statuses else ", ".join(sorted(statuses)) or None)
            if brush in with_paper:
                paper = PAPER_PSNR.get((dict(zip(keys, setting)).get("renderer"), brush))
                row.append(None if paper is None else f"{paper:.2f}")
        rows.append(row)
    return header, rows


def margins(jobs: list[Job]) -> tuple[list[str], list[list]] | None:
    """Dual's margin over every other renderer per brush: dual's headline metric minus theirs, mean ± std
    over the seeds both ran (paired: a seed draws the same training strokes). None unless ``dual`` and
    another renderer were swept, each with one setting (other swept keys go with the renderer)."""
    metric, renderers, brushes = headline(jobs), choices(jobs, "renderer"), choices(jobs, PANEL)
    settings = {tuple(job.choice(k) for k in group_keys(jobs)) for job in jobs}
    if not is_renderer_sweep(jobs) or len(settings) != len(renderers) or DUAL not in renderers or len(renderers) < 2:
        return None

    def scores(renderer: str, brush: str) -> dict:
        return {job.choice(SEED): score(job, metric) for job in jobs if score(job, metric) is not None
                and (job.choice("renderer"), job.choice(PANEL)) == (renderer, brush)}

    header, rows = ["dual minus", *map(str, brushes)], []
    for other in (r for r in renderers if r != DUAL):
        row: list = [other]
        for brush in brushes:
            dual, theirs = scores(DUAL, brush), scores(other, brush)
            paired = Stat([dual[s] - theirs[s] for s in dual if s in theirs])
            row.append(significance(paired) if paired.values else None)
        rows.append(row)
    return header, rows


def significance(paired: Stat) -> str:
    """A paired difference over seeds as a cell: ``+0.43 ± 0.43 [−0.63, +1.49] p=0.23``, its mean ±
    std, the 95 % confidence interval of the mean and the two-sided p of Student's one-sample t-test
    against 0 (scipy.stats.ttest_1samp); the difference alone for one seed."""
    if len(paired.values) < 2:
        return f"{paired.mean:+.2f}"
    from scipy.stats import ttest_1samp

    test = ttest_1samp(paired.values, 0.0)
    low, high = test.confidence_interval(0.95)
    return f"{paired.mean:+.2f} ± {paired.std:.2f} [{low:+.2f}, {high:+.2f}] p={test.pvalue:.2g}"


def chosen_rates(jobs: list[Job]) -> tuple[list[str], list[list]] | None:
    """For a learning-rate study: per renderer, the validation score at each rate averaged over brushes
    (and seeds), and the rate with the best average. None unless ``renderer`` and the rate are swept."""
    if headline(jobs) != "val/psnr" or not {"renderer", LR} <= set(swept_keys(jobs)):
        return None
    rates = sorted(choices(jobs, LR), key=rate_order)
    header, rows = ["renderer", *(f"lr={rate}" for rate in rates), "chosen"], []
    for renderer in choices(jobs, "renderer"):
        means, ran = {}, set()
        for rate in rates:
            cell = [job for job in jobs if (job.choice("renderer"), job.choice(LR)) == (renderer, rate)]
            score, ran = stat(cell, "val/psnr"), ran | ({rate} if cell else set())
            if score and len(score.values) == len(cell):  # a rate with a failed job is not chosen
                means[rate] = score.mean
        rows.append([renderer, *(f"{means[r]:.2f}" if r in means else "failed" if r in ran else None for r in rates),
                     max(means, key=means.get) if means else None])
    return header, rows


def rate_order(rate) -> tuple:
    """Rates by value; one that is not a number (a typo, none recorded) after them, by its text."""
    try:
        return 0, float(rate), ""
    except (TypeError, ValueError):
        return 1, 0.0, str(rate)


def renderer_order(name: str) -> tuple:
    """Renderers in :data:`RENDERERS`' order; any other before the analytic one, by name."""
    return (RENDERERS.index(name) if name in RENDERERS else len(RENDERERS) - 1, name)


def is_painting_study(jobs: list[Job]) -> bool:
    """Jobs of ``experiment=renderer_painting``: paintings, each through a trained or the analytic renderer."""
    return any(STUDY_RENDERER in job.overrides and "brush" in job.metrics for job in jobs)


def painting_scores(jobs: list[Job], brush: str) -> dict[tuple[str, int], dict[object, dict[str, float]]]:
    """(renderer, budget) -> seed (a network's training seed, the analytic renderer's painter seed) -> the
    mean over photos of ``psnr``, ``ssim``,
    ``painting_seconds`` and the checkpoint's ``renderer_psnr``, over the completed paintings of ``brush``."""
    cells: dict = {}
    for job in jobs:
        if job.status == "completed" and job.metrics.get("brush") == brush and score(job, "psnr") is not None:
            key = (str(job.metrics.get("renderer")), int(job.metrics.get("strokes", 0)))
            cells.setdefault(key, {}).setdefault(job.metrics.get("seed"), []).append(job.metrics)
    keys = ("psnr", "ssim", "painting_seconds", "renderer_psnr")
    return {cell: {seed: {k: statistics.fmean(m[k] for m in runs) for k in keys if all(isinstance(m.get(k), Number) for m in runs)}
                   for seed, runs in seeds.items()} for cell, seeds in cells.items()}


def painting_table(jobs: list[Job], brush: str) -> tuple[list[str], list[list]]:
    """A row per renderer (the analytic one last): its test PSNR, then per stroke budget the painting's
    PSNR, SSIM and seconds, each the mean over photos, as mean ± std over seeds."""
    scores = painting_scores(jobs, brush)
    budgets = sorted({b for _, b in scores})
    header = ["renderer", "test PSNR", *(f"{name} @{b}" for b in budgets for name in ("PSNR", "SSIM", "seconds"))]

    def cell(values: list[float], spec: str) -> str | None:
        return format(Stat(values), spec) if values else None

    rows = []
    for renderer in sorted({r for r, _ in scores}, key=renderer_order):
        seeds = next(scores[(renderer, b)] for b in budgets if (renderer, b) in scores)
        row: list = [renderer, cell([s["renderer_psnr"] for s in seeds.values() if "renderer_psnr" in s], ".2f")]
        for budget in budgets:
            runs = scores.get((renderer, budget), {}).values()
            row += [cell([s[k] for s in runs if k in s], spec)
                    for k, spec in (("psnr", ".2f"), ("ssim", ".3f"), ("painting_seconds", ".1f"))]
        rows.append(row)
    return header, rows


def painting_margins(jobs: list[Job], brush: str) -> tuple[list[str], list[list]] | None:
    """The analytic renderer's margin in painting PSNR over each trained one, a column per stroke budget:
    the paired difference over seeds (seed s of each; each the mean over photos) as :func:`significance`
    writes it. None without the analytic renderer and a trained one."""
    scores = painting_scores(jobs, brush)
    budgets, renderers = sorted({b for _, b in scores}), sorted({r for r, _ in scores}, key=renderer_order)
    if ANALYTIC not in renderers or len(renderers) < 2:
        return None
    rows = []
    for renderer in (r for r in renderers if r != ANALYTIC):
        row: list = [renderer]
        for budget in budgets:
            ours, theirs = scores.get((ANALYTIC, budget), {}), scores.get((renderer, budget), {})
            paired = Stat([ours[s]["psnr"] - theirs[s]["psnr"] for s in ours if s in theirs])
            row.append(significance(paired) if paired.values else None)
        rows.append(row)
    return ["analytic minus", *(f"@{b}" for b in budgets)], rows


def to_csv(header: list[str], rows: list[list]) -> str:
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerows([header, *(["" if v is None else v for v in row] for row in rows)])
    return out.getvalue()


def to_markdown(header: list[str], rows: list[list]) -> str:
    """A GitHub markdown table; absent values show as —, numbers (and ``mean ± std``) right-aligned,
    and a column with no value in any row is left out."""
    def absent(value) -> bool:
        return value is None or (isinstance(value, float) and math.isnan(value))

    def numeric(value) -> bool:
        return value is None or isinstance(value, Number) or (isinstance(value, str) and _is_number(value.split(" ± ")[0]))

    kept = [i for i in range(len(header)) if not all(absent(row[i]) for row in rows)] if rows else list(range(len(header)))
    header, rows = [header[i] for i in kept], [[row[i] for i in kept] for row in rows]
    right = [all(numeric(row[i]) for row in rows) for i in range(len(header))]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---:" if r else "---" for r in right) + "|"]
    lines += ["| " + " | ".join("—" if absent(v) else str(v) for v in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
