"""``python -m nsp.report``: a fabricated multirun dir gives exactly the expected tables; failed jobs show."""
import json
from pathlib import Path

import pytest
from torch.utils.tensorboard import SummaryWriter

from nsp.report import main
from nsp.reporting import write_report


def fake_job(sweep: Path, num: int, overrides: list[str], metrics: dict | None, psnr_curve=()) -> None:
    """A job dir as Hydra and nsp.train leave it: .hydra/{hydra,overrides}.yaml, metrics.json, events."""
    job = sweep / f"{num}_job"
    (job / ".hydra").mkdir(parents=True)
    (job / ".hydra" / "hydra.yaml").write_text(f"hydra:\n  mode: MULTIRUN\n  job:\n    num: {num}\n")
    (job / ".hydra" / "overrides.yaml").write_text("".join(f"- {line}\n" for line in overrides))
    if metrics is not None:
        (job / "metrics.json").write_text(json.dumps(metrics))
    if psnr_curve:
        with SummaryWriter(job / "tensorboard") as writer:
            for step, value in psnr_curve:
                writer.add_scalar("val/psnr", value, step)


def train_metrics(renderer: str, brush: str, psnr: float, status: str = "completed") -> dict:
    return {"val/psnr": psnr, "steps": 100, "seconds": 9.5, "renderer": renderer, "brush": brush, "status": status}


@pytest.fixture
def renderer_sweep(tmp_path: Path) -> Path:
    common = ["experiment=renderer_ablation", "trainer.max_steps=100"]
    fake_job(tmp_path, 0, ["renderer=dual_raster", "brush=oilpaint", *common], train_metrics("dual_raster", "oilpaint", 20.5),
             [(50, 15.0), (100, 20.5)])
    fake_job(tmp_path, 1, ["renderer=dual_raster", "brush=watercolor", *common], train_metrics("dual_raster", "watercolor", 22.25),
             [(50, 18.0), (100, 22.25)])
    fake_job(tmp_path, 2, ["renderer=dual", "brush=oilpaint", *common], train_metrics("dual", "oilpaint", 23.0),
             [(50, 19.0), (100, 23.0)])
    fake_job(tmp_path, 3, ["renderer=dual", "brush=watercolor", *common], None)  # crashed before writing metrics
    return tmp_path


def test_renderer_sweep_report_is_exactly_the_expected_tables(renderer_sweep):
    written = write_report(renderer_sweep)
    assert [p.name for p in written] == ["report.md", "report.csv", "val_psnr.png"]
    assert (renderer_sweep / "report.csv").read_text() == (
        "job,renderer,brush,status,val/psnr,steps,seconds\n"
        "0,dual_raster,oilpaint,completed,20.5,100,9.5\n"
        "1,dual_raster,watercolor,completed,22.25,100,9.5\n"
        "2,dual,oilpaint,completed,23.0,100,9.5\n"
        "3,dual,watercolor,failed,,,\n"
    )
    report = (renderer_sweep / "report.md").read_text()
    assert "4 jobs: 3 completed, 1 failed." in report
    assert "Every job: `experiment=renderer_ablation` `trainer.max_steps=100`" in report
    assert (
        "| renderer | oilpaint | oilpaint (paper) | watercolor | watercolor (paper) |\n"
        "|---|---:|---:|---|---:|\n"
        "| dual_raster | 20.5 | 24.015 | 22.25 | 25.769 |\n"
        "| dual | 23.0 | 26.982 | failed | 31.389 |\n"
    ) in report
    assert "| 3 | dual | watercolor | failed | — | — | — |" in report
    assert "![val_psnr](val_psnr.png)" in report
    assert (renderer_sweep / "val_psnr.png").read_bytes()[:4] == b"\x89PNG"


def test_metrics_with_status_failed_is_reported_failed(tmp_path):
    fake_job(tmp_path, 0, ["renderer=dcgan"], train_metrics("dcgan", "tape", 12.0))
    fake_job(tmp_path, 1, ["renderer=unet"], train_metrics("unet", "tape", 13.0, status="failed"))
    write_report(tmp_path)
    rows = (tmp_path / "report.csv").read_text().splitlines()
    assert rows[2].startswith("1,unet,failed,13.0")
    assert "| unet | failed | — |" in (tmp_path / "report.md").read_text()  # its score is no result; tape: not in the paper


def test_painting_sweep_reports_its_own_metrics_and_no_renderer_table(tmp_path):
    fake_job(tmp_path, 0, ["experiment=ot_push", "loss=l1"], {"psnr": 20.0, "position_error": 0.31, "seconds": 2.0})
    fake_job(tmp_path, 1, ["experiment=ot_push", "loss=l1_ot"], {"psnr": 31.0, "position_error": 0.02, "seconds": 3.0})
    write_report(tmp_path)
    assert (tmp_path / "report.csv").read_text() == (
        "job,loss,status,psnr,position_error,seconds\n0,l1,completed,20.0,0.31,2.0\n1,l1_ot,completed,31.0,0.02,3.0\n"
    )
    assert "by renderer and brush" not in (tmp_path / "report.md").read_text()


@pytest.mark.parametrize("make", [lambda p: p / "missing", lambda p: p])  # absent; a dir without jobs
def test_bad_dir_is_a_one_line_error_naming_it(tmp_path, make):
    path = make(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main([str(path)])
    message = exit_.value.code
    assert isinstance(message, str) and "\n" not in message
    assert str(path) in message and ".hydra/overrides.yaml" in message
