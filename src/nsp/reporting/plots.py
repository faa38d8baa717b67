"""Plots of a multirun, a panel per brush and a line or bar per setting (its swept choices but the seed,
as ``key=value``): every TensorBoard scalar some job logged at two steps or more (validation scores at
one, marked), mean over seeds with their range shaded; and bars of the headline metric at the end, mean
± std over seeds, so a sweep too short for curves still gets a picture."""
from __future__ import annotations

import statistics
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display on clusters or in tests
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
import numpy as np  # noqa: E402

from nsp.reporting.collect import Job, swept_keys  # noqa: E402
from nsp.reporting.tables import (PANEL, choices, group_keys, headline, is_painting_study, label,  # noqa: E402
                                  painting_scores, renderer_order, stat)

SKIPPED = {"epoch"}  # Lightning's bookkeeping, not a measurement


def panels(jobs: list[Job]) -> list:
    """The brushes when they are swept (one panel each), else one panel (None)."""
    return choices(jobs, PANEL) if PANEL in swept_keys(jobs) else [None]


def settings(jobs: list[Job], panel) -> dict[str, list[Job]]:
    """Jobs of one panel grouped by setting label, in first-seen order, renderers in the paper's."""
    keys, groups = group_keys(jobs), {}
    for job in sorted(jobs, key=lambda job: renderer_order(str(job.choice("renderer")))) if "renderer" in keys else jobs:
        if panel is None or job.choice(PANEL) == panel:
            groups.setdefault(label(job, keys) or f"job {job.num}", []).append(job)
    return groups


def curve_tags(jobs: list[Job]) -> list[str]:
    """Scalar tags with two points or more in some job, and validation scores however few (a short run
    validates once); other single points are final values, in the tables."""
    tags = dict.fromkeys(tag for job in jobs for tag, points in job.curves.items()
                         if len(points) > 1 or (points and tag.startswith("val/")))
    return [tag for tag in tags if tag not in SKIPPED]


def plot_tag(jobs: list[Job], tag: str) -> Figure:
    """``tag`` against step, a line per setting (mean over its seeds, range shaded)."""
    columns = panels(jobs)
    names = list(dict.fromkeys(name for panel in columns for name in settings(jobs, panel)))  # one colour a setting
    fig, axes = plt.subplots(1, len(columns), figsize=(5 * len(columns), 3.6), squeeze=False, sharey=True)
    for ax, panel in zip(axes[0], columns):
        groups = settings(jobs, panel)
        for name, group in ((name, groups[name]) for name in names if name in groups):
            runs = [{step: value for step, value in job.curves[tag] if np.isfinite(value)} for job in group if tag in job.curves]
            if not runs:
                continue
            steps = sorted(set.intersection(*(set(run) for run in runs)))
            values = np.array([[run[s] for s in steps] for run in runs])
            complete = all(job.status == "completed" for job in group)
            line, = ax.plot(steps, values.mean(0), label=name + ("" if complete else " (not all completed)"),
                            color=f"C{names.index(name) % 10}", linestyle="-" if complete else "--",
                            marker="o" if len(steps) < 3 else None)
            if len(runs) > 1:
                ax.fill_between(steps, values.min(0), values.max(0), color=line.get_color(), alpha=0.2, linewidth=0)
        ax.set(title=f"{PANEL}={panel}" if panel is not None else tag, xlabel="step")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0][0].set_ylabel(tag + (" (dB)" if "psnr" in tag else ""))
    return fig


def plot_bars(jobs: list[Job], metric: str) -> Figure:
    """Final ``metric`` per setting as horizontal bars from zero (mean ± std over seeds, where several)."""
    columns = panels(jobs)
    names = list(dict.fromkeys(name for panel in columns for name in settings(jobs, panel)))
    fig, axes = plt.subplots(1, len(columns), figsize=(4.5 * len(columns) + 2, 0.8 + 0.32 * len(names)),
                             squeeze=False, sharey=True)
    low, high = np.inf, -np.inf
    for ax, panel in zip(axes[0], columns):
        groups = settings(jobs, panel)
        stats = [stat(groups[name], metric) if name in groups else None for name in names]
        means = np.array([s.mean if s and np.isfinite(s.mean) else np.nan for s in stats])  # no bar for an infinite PSNR
        errors = np.array([s.std if s else 0.0 for s in stats])
        ax.barh(range(len(names)), means, xerr=errors, capsize=3, color="tab:blue", alpha=0.8)
        for y, (mean, error) in enumerate(zip(means, errors)):
            if np.isfinite(mean):
                ax.text(mean + error, y, f" {mean:.2f}", va="center", fontsize=7)
        spread = "mean ± std over seeds" if max(map(len, groups.values()), default=0) > 1 else "one run each"
        ax.set(title=f"{PANEL}={panel}" if panel is not None else metric,
               xlabel=f"{metric}{' (dB)' if 'psnr' in metric else ''}, {spread}")
        ax.grid(alpha=0.3, axis="x")
        if np.isfinite(means).any():
            low, high = min(low, np.nanmin(means)), max(high, np.nanmax(means + errors))
    axes[0][0].set_yticks(range(len(names)), names, fontsize=8)
    axes[0][0].invert_yaxis()  # first setting on top, as in the tables
    if np.isfinite(high):  # bars from zero, so their lengths compare; the numbers beside them tell the gaps
        for ax in axes[0]:
            ax.set_xlim(min(0.0, low), 1.15 * high if high > 0 else None)
    return fig


def plot_painting_study(jobs: list[Job]) -> Figure:
    """Renderer test PSNR against painting PSNR, a panel per brush: a point per checkpoint and stroke
    budget (its painting PSNR the mean over photos), the analytic renderer a dashed line per budget (the
    mean over its painter seeds)."""
    brushes = list(dict.fromkeys(job.metrics["brush"] for job in jobs if "brush" in job.metrics))
    fig, axes = plt.subplots(1, len(brushes), figsize=(5 * len(brushes), 4), squeeze=False)
    markers, lines = iter("osD^v<>p*h"), iter(["--", ":", "-.", (0, (5, 5))] * 3)
    shape: dict[int, tuple] = {}
    for ax, brush in zip(axes[0], brushes):
        scores = painting_scores(jobs, brush)
        renderers = sorted({r for r, _ in scores if r != "analytic"})
        for (renderer, budget), seeds in sorted(scores.items()):
            if budget not in shape:
                shape[budget] = next(markers), next(lines)
            marker, line = shape[budget]
            if renderer == "analytic":
                ax.axhline(statistics.fmean(s["psnr"] for s in seeds.values()), color="black", linestyle=line, linewidth=1, label=f"analytic, {budget} strokes")
                continue
            points = [(s["renderer_psnr"], s["psnr"]) for s in seeds.values() if "renderer_psnr" in s]
            color = f"C{renderers.index(renderer)}"
            ax.scatter(*zip(*points), marker=marker, color=color, label=f"{renderer}, {budget} strokes")
        ax.set(title=f"{PANEL}={brush}", xlabel="renderer test PSNR (dB)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("painting PSNR (dB), mean over photos")
    return fig


def plot_all(jobs: list[Job], out: Path) -> list[Path]:
    """Write every curve's ``<tag>.png`` and the headline's ``final_<metric>.png`` (``/`` as ``_``) into
    ``out``, a renderer → painting study's ``renderer_vs_painting.png`` instead; returns the files."""
    if is_painting_study(jobs):  # its paintings' own curves (loss per step, one a job) would be hundreds of lines
        return [save(plot_painting_study(jobs), out / "renderer_vs_painting.png")]
    paths = [save(plot_tag(jobs, tag), out / f"{tag.replace('/', '_')}.png") for tag in curve_tags(jobs)]
    if metric := headline(jobs):
        paths.append(save(plot_bars(jobs, metric), out / f"final_{metric.replace('/', '_')}.png"))
    return paths


def save(fig: Figure, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
