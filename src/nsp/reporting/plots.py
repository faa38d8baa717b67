"""Plots of a multirun's TensorBoard curves: one figure per scalar tag, a panel per brush, a line per
job labelled by its other swept choices (the renderer, in a renderer sweep)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display on clusters or in tests
import matplotlib.pyplot as plt  # noqa: E402

from nsp.reporting.collect import Job, swept_keys  # noqa: E402

PANEL_KEY = "brush"
SKIPPED = {"epoch"}  # Lightning's bookkeeping, not a measurement


def curve_tags(jobs: list[Job]) -> list[str]:
    """Scalar tags with at least two points in some job (single points are final values, in the tables)."""
    tags = dict.fromkeys(tag for job in jobs for tag, points in job.curves.items() if len(points) > 1)
    return [tag for tag in tags if tag not in SKIPPED]


def plot_tag(jobs: list[Job], tag: str, path: Path) -> None:
    """``tag`` against step for every job that logged it, saved to ``path`` (PNG)."""
    swept = swept_keys(jobs)
    panels = list(dict.fromkeys(job.choice(PANEL_KEY) for job in jobs)) if PANEL_KEY in swept else [None]
    labels = [key for key in swept if key != PANEL_KEY]
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 3.6), squeeze=False, sharey=True)
    for ax, panel in zip(axes[0], panels):
        for job in jobs:
            if tag not in job.curves or (panel is not None and job.choice(PANEL_KEY) != panel):
                continue
            steps, values = zip(*job.curves[tag])
            label = " ".join(str(job.overrides.get(key)) for key in labels) or f"job {job.num}"
            if job.status != "completed":
                label += f" ({job.status})"
            ax.plot(steps, values, label=label, linestyle="-" if job.status == "completed" else "--")
        ax.set_title(panel if panel is not None else tag)
        ax.set_xlabel("step")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0][0].set_ylabel(tag)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_curves(jobs: list[Job], out: Path) -> list[Path]:
    """One ``<tag>.png`` (``/`` as ``_``) per curve tag in ``out``; returns the files written."""
    paths = []
    for tag in curve_tags(jobs):
        path = out / f"{tag.replace('/', '_')}.png"
        plot_tag(jobs, tag, path)
        paths.append(path)
    return paths
