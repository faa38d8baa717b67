"""Turning a Hydra multirun into tables and plots (``python -m nsp.report DIR``)."""
from __future__ import annotations

from collections import Counter
from pathlib import Path

from nsp.reporting.collect import Job, collect, common_overrides
from nsp.reporting.plots import plot_curves
from nsp.reporting.tables import is_renderer_sweep, job_rows, pivot, to_csv, to_markdown


def write_report(sweep: Path) -> list[Path]:
    """Write ``report.md``, ``report.csv`` and the curve plots of the multirun in ``sweep`` into it.

    Returns the files written. Raises ``ValueError`` when ``sweep`` holds no Hydra job.
    """
    jobs = collect(sweep)
    header, rows = job_rows(jobs)
    (sweep / "report.csv").write_text(to_csv(header, rows))
    plots = plot_curves(jobs, sweep)
    (sweep / "report.md").write_text(markdown(sweep, jobs, plots))
    return [sweep / "report.md", sweep / "report.csv", *plots]


def markdown(sweep: Path, jobs: list[Job], plots: list[Path]) -> str:
    """The report: what ran, the job table, the renderer × brush pivot (renderer sweeps), the plots."""
    statuses = Counter(job.status for job in jobs)
    counts = ", ".join(f"{n} {status}" for status, n in statuses.most_common())
    lines = [f"# Report: {sweep.name}", "", f"{len(jobs)} jobs: {counts}."]
    if common := common_overrides(jobs):
        lines += ["", "Every job: " + " ".join(f"`{key}={value}`" for key, value in common.items())]
    lines += ["", "## Jobs", "", to_markdown(*job_rows(jobs))]
    if is_renderer_sweep(jobs):
        lines += ["## Final val/psnr (dB) by renderer and brush", "",
                  "Paper: Table 1 (128 px); Fig. 9 gives curves only (—).", "", to_markdown(*pivot(jobs))]
    if plots:
        lines += ["## Curves", ""] + [f"![{path.stem}]({path.name})" for path in plots] + [""]
    return "\n".join(lines)


__all__ = ["Job", "collect", "write_report"]
