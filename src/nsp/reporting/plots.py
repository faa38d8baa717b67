"""Plots of a multirun, a panel per brush and a line or bar per setting (its swept choices but the
seed, named ``key=value``):

- curves: every TensorBoard scalar that some job logged at two steps or more, the mean over seeds
  with their range shaded;
- bars: the headline metric at the end, mean over seeds with ± std error bars, drawn for every sweep
  that has one (so a sweep too short for curves still gets a picture).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display on clusters or in tests
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from nsp.reporting.collect import Job, swept_keys  # noqa: E402
from nsp.reporting.tables import PANEL, group_keys, headline, label, stat  # noqa: E402

SKIPPED = {"epoch"}  # Lightning's bookkeeping, not a measurement


def panels(jobs: list[Job]) -> list:
    """The brushes when they are swept (one panel each), else one panel (None)."""
    return list(dict.fromkeys(job.choice(PANEL) for job in jobs)) if PANEL in swept_keys(jobs) else [None]


def settings(jobs: list[Job], panel) -> dict[str, list[Job]]:
    """Jobs of one panel grouped by setting label, in first-seen order."""
    keys, groups = group_keys(jobs), {}
    for job in jobs:
        if panel is None or job.choice(PANEL) == panel:
            groups.setdefault(label(job, keys) or f"job {job.num}", []).append(job)
    return groups


def curve_tags(jobs: list[Job]) -> list[str]:
    """Scalar tags with at least two points in some job (single points are final values, in the tables)."""
    tags = dict.fromkeys(tag for job in jobs for tag, points in job.curves.items() if len(points) > 1)
    return [tag for tag in tags if tag not in SKIPPED]


def figure(count: int):
    fig, axes = plt.subplots(1, count, figsize=(5 * count, 3.6), squeeze=False, sharey=True)
    return fig, axes[0]


def plot_tag(jobs: list[Job], tag: str, path: Path) -> None:
    """``tag`` against step, a line per setting (mean over its seeds, range shaded), saved to ``path``."""
    columns = panels(jobs)
    fig, axes = figure(len(columns))
    for ax, panel in zip(axes, columns):
        for name, group in settings(jobs, panel).items():
            runs = [dict(job.curves[tag]) for job in group if tag in job.curves]
            if not runs:
                continue
            steps = sorted(set.intersection(*(set(run) for run in runs)))
            values = np.array([[run[s] for s in steps] for run in runs])
            complete = all(job.status == "completed" for job in group)
            line, = ax.plot(steps, values.mean(0), label=name + ("" if complete else " (not all completed)"),
                            linestyle="-" if complete else "--")
            if len(runs) > 1:
                ax.fill_between(steps, values.min(0), values.max(0), color=line.get_color(), alpha=0.2, linewidth=0)
        ax.set_title(f"{PANEL}={panel}" if panel is not None else tag)
        ax.set_xlabel("step")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel(tag)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_bars(jobs: list[Job], metric: str, path: Path) -> None:
    """Final ``metric`` per setting, mean over seeds with ± std error bars, saved to ``path``."""
    columns = panels(jobs)
    fig, axes = figure(len(columns))
    for ax, panel in zip(axes, columns):
        groups = settings(jobs, panel)
        stats = [stat(group, metric) for group in groups.values()]
        means = [s.mean if s else np.nan for s in stats]
        errors = [s.std if s else 0.0 for s in stats]
        ax.bar(range(len(groups)), means, yerr=errors, capsize=4, color="tab:blue", alpha=0.8)
        ax.set_xticks(range(len(groups)), list(groups), rotation=20, ha="right", fontsize=8)
        ax.set_title(f"{PANEL}={panel}" if panel is not None else metric)
        ax.grid(alpha=0.3, axis="y")
        finite = [m for m in means if np.isfinite(m)]
        if finite:  # PSNRs differ by a few dB on top of ~20: start the axis near the lowest bar
            low, high = min(finite), max(m + e for m, e in zip(means, errors) if np.isfinite(m))
            ax.set_ylim(low - 0.1 * (high - low + 1), high + 0.1 * (high - low + 1))
    axes[0].set_ylabel(f"{metric} (mean ± std over seeds)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_all(jobs: list[Job], out: Path) -> list[Path]:
    """Every curve's ``<tag>.png`` and the headline's ``final_<metric>.png`` (``/`` as ``_``) in ``out``;
    returns the files written."""
    paths = []
    for tag in curve_tags(jobs):
        paths.append(out / f"{tag.replace('/', '_')}.png")
        plot_tag(jobs, tag, paths[-1])
    if metric := headline(jobs):
        paths.append(out / f"final_{metric.replace('/', '_')}.png")
        plot_bars(jobs, metric, paths[-1])
    return paths
