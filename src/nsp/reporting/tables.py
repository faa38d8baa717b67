"""Tables of a multirun: one row per job (CSV and markdown) and, for renderer sweeps, the final
validation PSNR by renderer and brush beside the paper's."""
from __future__ import annotations

import csv
import io
import math
from numbers import Number

from nsp.reporting.collect import Job, swept_keys

# Paper Table 1 (128 px, mean PSNR of foreground and alpha, dB); Fig. 9 gives curves, no numbers.
PAPER_PSNR = {
    ("dual_raster", "oilpaint"): 24.015, ("dual_shading", "oilpaint"): 26.048, ("dual", "oilpaint"): 26.982,
    ("dual_raster", "watercolor"): 25.769, ("dual_shading", "watercolor"): 29.045, ("dual", "watercolor"): 31.389,
}
PIVOT_METRIC = "val/psnr"


def metric_keys(jobs: list[Job]) -> list[str]:
    """Numeric metrics any job recorded, in first-seen order; text (the brush's name, the status) has
    its own columns."""
    swept = set(swept_keys(jobs))
    keys = dict.fromkeys(
        key for job in jobs for key, value in job.metrics.items() if isinstance(value, Number) and not isinstance(value, bool)
    )
    return [key for key in keys if key not in swept]


def job_rows(jobs: list[Job]) -> tuple[list[str], list[list]]:
    """Header and rows: job number, swept choices, status, final metrics (None where absent)."""
    swept, metrics = swept_keys(jobs), metric_keys(jobs)
    header = ["job", *swept, "status", *metrics]
    rows = [[job.num, *(job.overrides.get(k) for k in swept), job.status, *(job.metrics.get(k) for k in metrics)] for job in jobs]
    return header, rows


def is_renderer_sweep(jobs: list[Job]) -> bool:
    return "renderer" in swept_keys(jobs) and any(PIVOT_METRIC in job.metrics for job in jobs)


def pivot(jobs: list[Job]) -> tuple[list[str], list[list]]:
    """Final ``val/psnr`` with rows renderer and columns brush, each brush beside the paper's number.

    A cell is the mean over the completed jobs of that renderer and brush (several when seeds are
    swept too); ``failed`` when none completed.
    """
    renderers = list(dict.fromkeys(job.choice("renderer") for job in jobs))
    brushes = list(dict.fromkeys(job.choice("brush") for job in jobs))
    header = ["renderer"] + [name for brush in brushes for name in (brush, f"{brush} (paper)")]
    rows = []
    for renderer in renderers:
        row: list = [renderer]
        for brush in brushes:
            cell = [j for j in jobs if (j.choice("renderer"), j.choice("brush")) == (renderer, brush)]
            scores = [j.metrics[PIVOT_METRIC] for j in cell if PIVOT_METRIC in j.metrics and j.status != "failed"]
            measured = round(sum(scores) / len(scores), 3) if scores else ("failed" if cell else None)
            row += [measured, PAPER_PSNR.get((renderer, brush))]
        rows.append(row)
    return header, rows


def to_csv(header: list[str], rows: list[list]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    writer.writerows([["" if v is None else v for v in row] for row in rows])
    return out.getvalue()


def to_markdown(header: list[str], rows: list[list]) -> str:
    """A GitHub markdown table; absent values show as —, numbers right-aligned."""
    def cell(value) -> str:
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return "—"
        return str(value)

    numeric = [all(isinstance(row[i], Number) or row[i] is None for row in rows) for i in range(len(header))]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---:" if n else "---" for n in numeric) + "|"]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"
