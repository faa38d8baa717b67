"""``python -m nsp.report``: a fabricated multirun dir gives exactly the expected tables; failed jobs show."""
import errno
import json
import os
import re
from pathlib import Path

import matplotlib.pyplot as plt
import pytest
from matplotlib.figure import Figure
from torch.utils.tensorboard import SummaryWriter

from nsp.report import cli
from nsp.reporting import write_report
from nsp.reporting.collect import collect


def fake_job(sweep: Path, num: int | str, overrides: list[str], metrics: dict | None, psnr_curve=()) -> None:
    """A job dir as Hydra and nsp.train leave it: .hydra/{hydra,overrides}.yaml, metrics.json, events.
    A ``num`` that is a name makes a single run's dir of that name (Hydra gives it no job number)."""
    single = isinstance(num, str)
    job = sweep / (num if single else f"{num}_job")
    (job / ".hydra").mkdir(parents=True)
    (job / ".hydra" / "hydra.yaml").write_text(f"hydra:\n  mode: {'RUN' if single else 'MULTIRUN'}\n  job:\n"
                                               f"    num: {'???' if single else num}\n")
    (job / ".hydra" / "overrides.yaml").write_text("".join(f"- {line}\n" for line in overrides))
    if metrics is not None:
        (job / "metrics.json").write_text(json.dumps(metrics))
    if psnr_curve:
        with SummaryWriter(job) as writer:
            for step, value in psnr_curve:
                writer.add_scalar("val/psnr", value, step)


def train_metrics(renderer: str, brush: str, psnr: float, status: str = "completed", **more) -> dict:
    return {"val/psnr": psnr, "steps": 100, "seconds": 9.5, "renderer": renderer, "brush": brush, "status": status, **more}


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
    assert [p.name for p in written] == ["report.md", "report.csv", "val_psnr.png", "final_val_psnr.png"]
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
        "| dual_raster | 20.50 | 24.02 | 22.25 | 25.77 |\n"
        "| dual | 23.00 | 26.98 | failed | 31.39 |\n"
    ) in report
    assert "| dual_raster | +2.50 |\n" in report  # dual's margin, one seed (no ± 0.00), where both ran: no watercolor column
    assert (
        "| job | renderer | brush | status | val/psnr | steps | seconds |\n"
        "|---:|---|---|---|---:|---:|---:|\n"
        "| 0 | dual_raster | oilpaint | completed | 20.50 | 100 | 9.5 |\n"
        "| 1 | dual_raster | watercolor | completed | 22.25 | 100 | 9.5 |\n"
        "| 2 | dual | oilpaint | completed | 23.00 | 100 | 9.5 |\n"
        "| 3 | dual | watercolor | failed | — | — | — |\n"
    ) in report
    assert "![val_psnr](val_psnr.png)" in report and "![final_val_psnr](final_val_psnr.png)" in report
    for plot in written[2:]:
        assert plot.read_bytes()[:4] == b"\x89PNG"


def test_seeds_pool_into_mean_and_std_of_the_test_score_with_paired_margins(tmp_path):
    scores = {("dcgan", 0): 19.0, ("dcgan", 1): 20.0, ("dcgan", 2): 21.0, ("dual", 0): 22.0, ("dual", 1): 22.5, ("dual", 2): 23.5}
    for num, ((renderer, seed), score) in enumerate(scores.items()):
        fake_job(tmp_path, num, [f"renderer={renderer}", "brush=oilpaint", f"seed={seed}"],
                 train_metrics(renderer, "oilpaint", 30.0, **{"test/psnr": score, "lr": 0.003 if renderer == "dual" else 0.001}))
    report = write_report(tmp_path)[0].read_text()
    assert "PSNR on the test strokes, mean ± std over 3 seeds" in report
    # Cells: the test score (not the validation one, 30.0), mean ± sample std over seeds, with each row's rate.
    assert (
        "| renderer | lr | oilpaint | oilpaint (paper) |\n|---|---:|---:|---:|\n"
        "| dcgan | 0.001 | 20.00 ± 1.00 | — |\n| dual | 0.003 | 22.67 ± 0.76 | 26.98 |\n"
    ) in report
    # Paired by seed: 3.0, 2.5, 2.5: mean 2.67, std 0.29, so t = 16 on 2 degrees of freedom (t* = 4.303).
    assert "| dcgan | +2.67 ± 0.29 [+1.95, +3.38] p=0.0039 |" in report
    assert (tmp_path / "final_test_psnr.png").is_file() and not (tmp_path / "val_psnr.png").exists()


def test_learning_rate_study_scores_validation_and_chooses_each_renderers_rate(tmp_path):
    val = {("pxlshuffle", "0.001"): (17.0, 17.5), ("pxlshuffle", "0.003"): (11.0, 11.5),
           ("dual", "0.001"): (21.0, 20.0), ("dual", "0.003"): (22.0, 20.5)}
    num = 0
    for (renderer, lr), pair in val.items():
        for brush, score in zip(("oilpaint", "watercolor"), pair):
            fake_job(tmp_path, num, [f"renderer={renderer}", f"brush={brush}", f"model.optimizer.lr={lr}"],
                     train_metrics(renderer, brush, score, **{"test/psnr": 99.0}))
            num += 1
    report = write_report(tmp_path)[0].read_text()
    assert "## Final val/psnr (dB) by renderer and brush" in report and "99.00" not in report.split("## Final")[1]
    assert "| renderer | lr=0.001 | lr=0.003 | chosen |\n|---|---:|---:|---:|\n" in report
    assert "| pxlshuffle | 17.25 | 11.25 | 0.001 |" in report and "| dual | 20.50 | 21.25 | 0.003 |" in report


def test_a_sweep_that_validated_once_gets_its_validation_points_and_bars_from_zero(tmp_path, monkeypatch):
    fake_job(tmp_path, 0, ["renderer=dcgan", "brush=tape"], train_metrics("dcgan", "tape", 12.0), [(30, 12.0)])
    fake_job(tmp_path, 1, ["renderer=dual", "brush=tape"], train_metrics("dual", "tape", 13.0), [(30, 13.0)])
    limits = []
    monkeypatch.setattr(plt.Axes, "set_xlim", lambda ax, *args, **kw: limits.append(args))
    assert [p.name for p in write_report(tmp_path)[2:]] == ["val_psnr.png", "final_val_psnr.png"]
    assert (0.0, 13.0 * 1.15) in limits  # the bars start at zero: a 1-dB gap does not fill the plot


def test_metrics_with_status_failed_is_reported_failed(tmp_path):
    fake_job(tmp_path, 0, ["renderer=dcgan"], train_metrics("dcgan", "tape", 12.0))
    fake_job(tmp_path, 1, ["renderer=unet"], train_metrics("unet", "tape", 13.0, status="failed"))
    write_report(tmp_path)
    rows = (tmp_path / "report.csv").read_text().splitlines()
    assert rows[2].startswith("1,unet,failed,13.0")
    assert "| unet | failed |\n" in (tmp_path / "report.md").read_text()  # its score is no result; no paper column for tape


def test_painting_sweep_reports_its_own_metrics_and_no_renderer_table(tmp_path):
    fake_job(tmp_path, 0, ["experiment=ot_push", "loss=l1"], {"psnr": 20.0, "position_error": 0.31, "seconds": 2.0})
    fake_job(tmp_path, 1, ["experiment=ot_push", "loss=l1_ot"], {"psnr": 31.0, "position_error": 0.02, "seconds": 3.0})
    write_report(tmp_path)
    assert (tmp_path / "report.csv").read_text() == (
        "job,loss,status,psnr,position_error,seconds\n0,l1,completed,20.0,0.31,2.0\n1,l1_ot,completed,31.0,0.02,3.0\n"
    )
    assert "by renderer and brush" not in (tmp_path / "report.md").read_text()


def test_without_a_dir_the_newest_multirun_is_reported(tmp_path, monkeypatch, capsys):
    for name, psnr in (("old", 11.0), ("new", 12.0)):
        sweep = tmp_path / "multirun" / "train" / name
        fake_job(sweep, 0, ["renderer=dcgan", "brush=tape"], train_metrics("dcgan", "tape", psnr))
        (sweep / "multirun.yaml").write_text("hydra: {}\n")
    monkeypatch.chdir(tmp_path)
    cli([])
    assert (tmp_path / "multirun" / "train" / "new" / "report.md").is_file()
    assert not (tmp_path / "multirun" / "train" / "old" / "report.md").exists()
    (tmp_path / "multirun").rename(tmp_path / "elsewhere")
    with pytest.raises(SystemExit):
        cli([])
    assert "multirun holds no multirun" in capsys.readouterr().err


def test_a_corrupt_metrics_file_is_a_failed_job_naming_it_and_mixed_runs_still_report(tmp_path):
    fake_job(tmp_path, 0, ["renderer=dcgan", "brush=tape"], train_metrics("dcgan", "tape", 12.0, **{"test/psnr": 11.5}))
    fake_job(tmp_path, 1, ["renderer=dual", "brush=tape"], None)
    (tmp_path / "1_job" / "metrics.json").write_text('{"val/psnr": 1')  # cut short by a kill
    fake_job(tmp_path, 2, ["image=astronaut", "strokes=10"], {"psnr": 18.0, "ssim": 0.5, "seconds": 2.0})  # a painting
    written = write_report(tmp_path)
    report = written[0].read_text()
    assert "3 jobs: 2 completed, 1 failed." in report
    assert "1_job/metrics.json is not valid JSON" in report
    assert all(path.is_file() for path in written)


def test_a_single_run_dir_and_a_folder_of_runs_are_reported(tmp_path, capsys):
    fake_job(tmp_path, "12-00-00_dcgan_tape", ["renderer=dcgan", "brush=tape"], train_metrics("dcgan", "tape", 12.0),
             [(50, 10.0), (100, 12.0)])
    run = tmp_path / "12-00-00_dcgan_tape"
    cli([str(run)])
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 1 and out[0].startswith("reported 1 run in ")  # one summary line, naming the report
    assert out[0].endswith(f": {run / 'report.md'} (and report.csv, 2 plots)")  # the curve and the bar chart
    report = (run / "report.md").read_text()
    assert "1 job: 1 completed." in report and (run / "val_psnr.png").is_file()
    assert "| job | val/psnr | steps | seconds |\n|---|---:|---:|---:|\n| 12-00-00_dcgan_tape | 12.00 | 100 | 9.5 |\n" in report

    fake_job(tmp_path, "12-05-00_dual_tape", ["renderer=dual", "brush=tape"], train_metrics("dual", "tape", 13.0))
    cli([str(tmp_path)])
    assert "| 12-00-00_dcgan_tape | dcgan | 12.00 |" in (tmp_path / "report.md").read_text()


def tables(report: str) -> list[list[list[str]]]:
    """The markdown tables of a report, each a list of rows of cells (header first, no rule line)."""
    blocks = re.findall(r"(?:^\|.*\|\n)+", report, flags=re.MULTILINE)
    return [[[c.strip() for c in line.strip("|").split("|")] for line in block.splitlines() if not line.startswith("|--")]
            for block in blocks]


def test_columns_that_say_nothing_are_left_out_and_each_metric_has_one_format(tmp_path):
    common = ["trainer.max_steps=100"]
    for num, (renderer, seed, psnr, seconds) in enumerate([("dcgan", 0, 20.5, 12.34), ("dcgan", 1, 21.0, 30.0),
                                                          ("dual", 0, 22.125, 7.0), ("dual", 1, 23.0, 101.5)]):
        fake_job(tmp_path, num, [f"renderer={renderer}", "brush=watercolor", f"seed={seed}", *common],
                 train_metrics(renderer, "watercolor", psnr, seconds=seconds, size=32, lr=0.003, seed=seed,
                               **{"test/psnr": psnr - 0.5, "ssim": 0.5}))
    fake_job(tmp_path, 4, ["renderer=dual_raster", "brush=tape", "seed=0", *common], train_metrics("dual_raster", "tape", 15.0))
    report = write_report(tmp_path)[0].read_text()
    # Shared by every job: the overrides, then metrics (the seed is an override; job 4 has no size); no status column.
    assert "Every job: `trainer.max_steps=100`\n" in report  # not again as the steps it ran
    jobs = tables(report)[0]
    assert jobs[0] == ["job", "renderer", "brush", "seed", "val/psnr", "seconds", "size", "lr", "test/psnr", "ssim"]
    assert jobs[1:3] == [["0", "dcgan", "watercolor", "0", "20.50", "12.3", "32", "0.003", "20.00", "0.5000"],
                         ["1", "dcgan", "watercolor", "1", "21.00", "30.0", "32", "0.003", "20.50", "0.5000"]]
    assert jobs[5] == ["4", "dual_raster", "tape", "0", "15.00", "9.5", "—", "—", "—", "—"]
    # No table has a column without a value: no "(paper)" column for tape, where the paper has no figure.
    for table in tables(report):
        for column in zip(*table[1:]):
            assert set(column) != {"—"}
    assert "tape (paper)" not in report and "watercolor (paper)" in report


def test_plot_legends_name_the_swept_keys(tmp_path, monkeypatch):
    for num, (lr, epoch_size) in enumerate([("4e-4", 6400), ("4e-4", 12800), ("1e-3", 6400), ("1e-3", 12800)]):
        fake_job(tmp_path, num, ["renderer=dcgan", f"model.optimizer.lr={lr}", f"data.epoch_size={epoch_size}"],
                 train_metrics("dcgan", "tape", 12.0), [(50, 10.0), (100, 12.0)])
    legends, savefig = [], Figure.savefig

    def save(fig: Figure, *args, **kwargs):  # the legend texts of every plot written
        legends.extend(text.get_text() for ax in fig.axes if ax.get_legend() for text in ax.get_legend().get_texts())
        return savefig(fig, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", save)
    write_report(tmp_path)
    assert legends == ["lr=4e-4 epoch_size=6400", "lr=4e-4 epoch_size=12800", "lr=1e-3 epoch_size=6400", "lr=1e-3 epoch_size=12800"]


def test_margins_also_when_dual_jobs_come_from_another_experiment(tmp_path):
    for num, (renderer, experiment, score) in enumerate([("dual_raster", "renderer_ablation", 20.0),
                                                        ("dual", "renderer_comparison", 22.5)]):
        fake_job(tmp_path, num, [f"experiment={experiment}", f"renderer={renderer}", "brush=oilpaint"],
                 train_metrics(renderer, "oilpaint", 1.0, **{"test/psnr": score}))
    report = write_report(tmp_path)[0].read_text()
    assert "| renderer_ablation | dual_raster |" in report and "| dual_raster | +2.50 |" in report


def test_jobs_of_an_aborted_sweep_that_never_began_are_rows_too(tmp_path):
    (tmp_path / "multirun.yaml").write_text(
        "hydra:\n  sweeper:\n    params:\n      renderer: dcgan,dual\n  overrides:\n    task:\n    - brush=tape,watercolor\n"
        "    - trainer.max_steps=100\n")
    for num, (renderer, brush) in enumerate([("dcgan", "tape"), ("dcgan", "watercolor")]):
        fake_job(tmp_path, num, [f"renderer={renderer}", f"brush={brush}", "trainer.max_steps=100"],
                 train_metrics(renderer, brush, 15.0 + num))
    jobs = collect(tmp_path)
    assert [(job.num, job.status) for job in jobs] == [(0, "completed"), (1, "completed"), (2, "not run"), (3, "not run")]
    assert jobs[3].overrides == {"renderer": "dual", "brush": "watercolor", "trainer.max_steps": "100"}
    report = write_report(tmp_path)[0].read_text()
    assert "4 jobs: 2 completed, 2 not run." in report
    assert "- job 2: the sweep ended before this job began" in report
    assert "| dual | not run | not run |" in report  # a sweep still to resume, not a failure


def test_a_rate_left_at_its_default_is_the_rate_the_run_recorded(tmp_path):
    fake_job(tmp_path, 0, ["renderer=dual", "brush=tape"], train_metrics("dual", "tape", 20.0, lr=1e-4))
    fake_job(tmp_path, 1, ["renderer=dual", "brush=tape", "model.optimizer.lr=1e-3"], train_metrics("dual", "tape", 21.0, lr=1e-3))
    fake_job(tmp_path, 2, ["renderer=unet", "brush=tape"], train_metrics("unet", "tape", 19.0, lr=1e-4))
    report = write_report(tmp_path)[0].read_text()
    assert "| renderer | lr=0.0001 | lr=1e-3 | chosen |\n" in report
    assert "| dual | 20.00 | 21.00 | 1e-3 |" in report and "| unet | 19.00 | — | 0.0001 |" in report


def _hydra(name: str, text: str):
    return lambda job: (job / ".hydra" / name).write_text(text)


MALFORMED = {  # what a hand-edited, half-copied or hostile run dir may hold -> what the report says of it
    "no hydra.yaml": (lambda job: (job / ".hydra" / "hydra.yaml").unlink(), None),
    "hydra.yaml not YAML": (_hydra("hydra.yaml", "{{{:"), None),
    "hydra.yaml a list": (_hydra("hydra.yaml", "- 1\n"), None),
    "job.num: abc": (_hydra("hydra.yaml", "hydra:\n  job:\n    num: abc\n"), None),
    "overrides not YAML": (_hydra("overrides.yaml", "- [unclosed\n: :"), "overrides.yaml is not a list of key=value lines"),
    "overrides of numbers": (_hydra("overrides.yaml", "- 5\n- null\n"), "overrides.yaml is not a list of key=value lines"),
    "metrics a list": (lambda job: (job / "metrics.json").write_text("[1, 2]"), "metrics.json is not valid JSON"),
    "status a list": (lambda job: (job / "metrics.json").write_text('{"val/psnr": 1, "status": ["done"]}'), None),
    "psnr text": (lambda job: (job / "metrics.json").write_text('{"val/psnr": "abc", "renderer": "dual"}'), None),
    "psnr Infinity": (lambda job: (job / "metrics.json").write_text('{"val/psnr": Infinity, "renderer": "dual"}'), None),
    "psnr 400 digits": (lambda job: (job / "metrics.json").write_text('{"val/psnr": 1%s}' % ("0" * 400)), "val/psnr is neither"),
    "seed a list": (lambda job: (job / "metrics.json").write_text('{"val/psnr": 3, "seed": [1]}'), "seed is neither"),
    "events a dir": (lambda job: (job / "events.out.tfevents.1.x").mkdir(), None),
    "events garbage": (lambda job: (job / "events.out.tfevents.1.y").write_bytes(bytes(range(256)) * 3), None),
}


@pytest.mark.parametrize("case", MALFORMED)
def test_malformed_run_metadata_is_reported_not_a_traceback(case, tmp_path, capsys):
    """Beside a good job, one whose files were damaged: the report is written, and says what it could not read."""
    fake_job(tmp_path, 0, ["renderer=dcgan", "brush=tape"], train_metrics("dcgan", "tape", 12.0), [(1, 10.0), (2, 12.0)])
    fake_job(tmp_path, 1, ["renderer=dual", "brush=tape"], train_metrics("dual", "tape", 13.0), [(1, 11.0), (2, 13.0)])
    damage, said = MALFORMED[case]
    damage(tmp_path / "1_job")
    cli([str(tmp_path)])
    assert capsys.readouterr().out.startswith("reported 2 runs")
    report = (tmp_path / "report.md").read_text()
    assert "| dcgan |" in report and "12.00" in report
    if said:
        assert said in report


def test_a_report_that_cannot_be_written_is_one_line_naming_the_dir(tmp_path, monkeypatch, capsys):
    fake_job(tmp_path, 0, ["renderer=dcgan", "brush=tape"], train_metrics("dcgan", "tape", 12.0))

    def read_only(self, *args, **kwargs):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(self))

    monkeypatch.setattr(Path, "write_text", read_only)
    with pytest.raises(SystemExit) as exit_:
        cli([str(tmp_path)])
    message = capsys.readouterr().err
    assert exit_.value.code == 2 and message.count("\n") == 1
    assert message == f"error: {tmp_path}: cannot write the report into it (Read-only file system); copy the runs to a folder you can write, and report that\n"
