"""docs/results.md quotes nsp.report: every cell of a committed study's tables (its scores and
dual's margins, with their intervals and p) stands in the page's section about it."""
import re
from pathlib import Path

import pytest

from nsp.reporting.collect import collect
from nsp.reporting.tables import is_painting_study, margins, painting_margins, painting_table, pivot

ROOT = Path(__file__).resolve().parent.parent
STUDIES = {  # the dir under studies/: the heading of its section in docs/results.md
    "renderer_lr_32px": "## Learning rates (the choice behind both tables)",
    "renderer_comparison_32px": "## Renderer comparison (paper Fig. 9)",
    "renderer_ablation_32px": "## Rasterization / shading ablation (paper Table 1)",
    "renderer_ablation_32px_watercolor": "## Rasterization / shading ablation (paper Table 1)",
    "renderer_lr_64px": "### Learning rates at 64 px",
    "renderer_comparison_64px": "### Renderer comparison at 64 px",
    "renderer_ablation_64px": "### Rasterization / shading ablation at 64 px",
    "renderer_painting_32px": "## Does a better renderer paint better? (32 px)",
}


def section(heading: str) -> str:
    """The text under ``heading`` up to the next heading of its level or above, bold unmarked."""
    text = (ROOT / "docs" / "results.md").read_text()
    start = text.index(heading + "\n")
    level = heading.split(" ")[0]
    end = re.compile(rf"^#{{1,{len(level)}}} ", re.M).search(text, start + len(heading))
    return text[start: end.start() if end else len(text)].replace("**", "")


def cells(study: str) -> list[str]:
    """What nsp.report prints of the study: each renderer's score on each brush (mean ± std over
    seeds, or one seed's), and dual's margins."""
    jobs = collect(ROOT / "studies" / study)
    if is_painting_study(jobs):  # each brush's table and the analytic renderer's margins
        tables = [table for brush in ("oilpaint", "watercolor") for table in (painting_table(jobs, brush), painting_margins(jobs, brush))]
        return [cell for _, rows in tables for row in rows for cell in row[1:] if cell]
    header, rows = pivot(jobs)
    brushes = [i for i, name in enumerate(header) if name in ("oilpaint", "watercolor")]
    paired = margins(jobs)
    return [row[i] for row in rows for i in brushes] + ([c for row in paired[1] for c in row[1:] if c] if paired else [])


@pytest.mark.parametrize("study", sorted(STUDIES))
def test_results_quote_the_studies_report(study):
    quoted = cells(study)
    assert len(quoted) >= 5
    text = section(STUDIES[study])
    missing = [cell for cell in quoted if cell not in text]
    assert not missing, f"docs/results.md, {STUDIES[study]!r}, lacks nsp.report's {missing}"


def test_the_64px_curves_rerun_ends_where_the_page_says():
    """The 64-px curves' study trained seed 0 again: the page says how far each ended from the tables' seed 0."""
    def seed0(study: str) -> dict[tuple, float]:
        return {(job.choice("renderer"), job.choice("brush")): job.metrics["test/psnr"]
                for job in collect(ROOT / "studies" / study) if job.choice("seed") in (0, "0")}

    tables = seed0("renderer_ablation_64px") | seed0("renderer_comparison_64px")
    again = {key: value for key, value in seed0("renderer_curves_64px").items() if key[0] != "dual_silhouette"}  # copied in
    apart = {key: round(value - tables[key], 2) for key, value in again.items() if abs(value - tables[key]) > 0.02}
    assert len(again) == 12 and apart == {("dual_raster", "oilpaint"): 0.11, ("dual", "watercolor"): 0.86}
    text = section("### Renderer comparison at 64 px")
    assert "Of the 12 jobs\ntrained again, 10 end within 0.02 dB" in text
    for key in apart:
        assert f"{again[key]:.2f} against {tables[key]:.2f}" in text.replace("\n", " ")
