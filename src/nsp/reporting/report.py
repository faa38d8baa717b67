"""The report of a multirun, a folder of runs or one run: ``report.md``, ``report.csv``, plots."""
from __future__ import annotations

from collections import Counter
from pathlib import Path

from nsp.errors import BadInput
from nsp.reporting.collect import Job, collect, common_overrides, swept_keys
from nsp.reporting.plots import plot_all
from nsp.reporting.tables import (SEED, chosen_rates, headline, is_painting_study, is_renderer_sweep, job_rows,
                                  margins, painting_margins, painting_table, pivot, shown_jobs, to_csv, to_markdown)
from nsp.text import counted


def write_report(sweep: Path) -> list[Path]:
    """Write ``report.md``, ``report.csv`` and the plots of the runs in ``sweep`` (a multirun's sweep
    dir, a folder of run dirs, or one run's dir) into it; returns the files written. Raises
    :class:`BadInput` when ``sweep`` holds no Hydra job or cannot be written into (read-only, full)."""
    jobs = collect(sweep)
    try:
        (sweep / "report.csv").write_text(to_csv(*job_rows(jobs)))
        plots = plot_all(jobs, sweep)
        (sweep / "report.md").write_text(markdown(sweep, jobs, plots))
    except OSError as error:
        raise BadInput(f"{sweep}: cannot write the report into it ({error.strerror or error}); "
                       "copy the runs to a folder you can write, and report that") from None
    return [sweep / "report.md", sweep / "report.csv", *plots]


def markdown(sweep: Path, jobs: list[Job], plots: list[Path]) -> str:
    """The report: what ran, the job table; for renderer sweeps the study's pivot, dual's margins and
    the chosen learning rates; the plots."""
    statuses = Counter(job.status for job in jobs)
    counts = ", ".join(f"{n} {status}" for status, n in sorted(statuses.items(), key=lambda item: (item[0] != "completed", -item[1])))
    lines = [f"# Report: {sweep.name}", "", f"{counted(len(jobs), 'job')}: {counts}."]
    header, rows, shared = shown_jobs(jobs)
    if common := common_overrides(jobs) | shared:
        lines += ["", "Every job: " + " ".join(f"`{key}={value}`" for key, value in common.items())]
    lines += ["", "## Jobs", "", to_markdown(header, rows)]
    if errors := [job for job in jobs if job.error]:
        lines += ["Why jobs did not complete, or what could not be read:", ""] + [f"- job {job.num}: {job.error}" for job in errors] + [""]
    trained = [job for job in jobs if job.choice("renderer") is not None]  # a folder may mix paintings in
    if trained and is_renderer_sweep(trained):
        jobs = trained
        seeds = len({job.choice(SEED) for job in jobs}) if SEED in swept_keys(jobs) else 1
        spread = f"mean ± std over {seeds} seeds" if seeds > 1 else "one seed"
        split = "validation" if headline(jobs) == "val/psnr" else "test"
        lines += [f"## Final {headline(jobs)} (dB) by renderer and brush", "",
                  f"PSNR on the {split} strokes, {spread}. Paper: Table 1 (128 px) where it gives a figure;"
                  " Fig. 9 gives curves only.", "", to_markdown(*pivot(jobs))]
        if table := margins(jobs):
            lines += ["## Dual's margin (dB)", "", f"dual minus each renderer, {spread} of the paired difference"
                      " (same seed, same training strokes); over several seeds, its 95 % confidence interval and the"
                      " two-sided p of a paired t-test. A margin whose interval holds 0 is a tie.", "",
                      to_markdown(*table)]
        if table := chosen_rates(jobs):
            lines += ["## Learning rate per renderer", "",
                      "Validation PSNR averaged over brushes; `chosen` is the best.", "", to_markdown(*table)]
    if is_painting_study(jobs):
        for brush in dict.fromkeys(job.metrics["brush"] for job in jobs if "brush" in job.metrics):
            lines += [f"## Painting through each renderer: {brush}", "",
                      "Each painting scored as the vector engine draws its strokes (PSNR, SSIM at a 256-px long side); "
                      "each cell the mean over photos, as mean ± std over seeds (a network's training seed, which"
                      " paints with the painter's seed alike; the analytic renderer's painter seed).", "",
                      to_markdown(*painting_table(jobs, brush))]
            if table := painting_margins(jobs, brush):
                lines += ["", f"The analytic renderer's margin in painting PSNR (dB), {brush}: the paired difference over"
                          " seeds, its 95 % confidence interval and the two-sided p of a paired t-test.", "",
                          to_markdown(*table)]
    if plots:
        lines += ["## Plots", ""] + [f"![{path.stem}]({path.name})" for path in plots] + [""]
    return "\n".join(lines)
