"""Every experiment file composes with its command's config, sweeps what the paper compares, and runs
a two-step version in-process; the launcher configs compose."""
import json
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from hydra.utils import instantiate

import nsp.painting.schema  # noqa: F401  (registers ``paint_schema``)
from nsp.training.run import train
from nsp.training.schema import register_configs

CONF = Path(__file__).parents[1] / "conf"
TINY_TRAIN = [
    "model.size=32", "model.channel_mult=0.125", "data.batch_size=8", "data.epoch_size=16", "data.val_size=16", "data.test_size=16",
    "trainer.max_steps=2", "trainer.accelerator=cpu", "trainer.num_sanity_val_steps=0", "trainer.log_every_n_steps=1",
]
COMPARISON, ABLATION, BRUSHES = "dcgan,pxlshuffle,unet,dual", "dual_raster,dual_shading,dual", "oilpaint,watercolor"
SWEEPS = {  # experiment: renderers, brushes, seeds
    "renderer_lr": ("dcgan,pxlshuffle,unet,dual,dual_raster,dual_shading", BRUSHES, "0"),
    "renderer_comparison": (COMPARISON, BRUSHES, "0,1,2"),
    "renderer_comparison_paper": (COMPARISON, BRUSHES, "0,1,2"),
    "renderer_ablation": (ABLATION, BRUSHES, "0,1,2"),
    "renderer_ablation_paper": (ABLATION, BRUSHES, "0,1,2"),
}


def compose_with_hydra(root: str, name: str, overrides: list[str]):
    with initialize_config_dir(str(CONF / root), version_base="1.3"):
        cfg = compose(name, overrides=overrides, return_hydra_config=True)
    HydraConfig.instance().set_config(cfg)  # as @hydra.main does: train() reads the runtime choices
    return cfg


def test_experiment_files_are_the_ones_tested():
    assert {p.stem for p in (CONF / "train" / "experiment").glob("*.yaml")} == set(SWEEPS)
    assert {p.stem for p in (CONF / "paint" / "experiment").glob("*.yaml")} == {"ot_push", "ot_digits", "renderer_painting", "style_dev",
                                                                                 "style_grid", "style_heldout"}  # style_*: tests/test_stylize.py


@pytest.mark.parametrize("experiment, size", [(name, size) for name in SWEEPS for size in ((32, 64) if "paper" not in name else (128,))])
def test_training_experiment_sweeps_the_papers_renderers_and_runs_two_steps(experiment, size, tmp_path):
    register_configs()
    cfg = compose_with_hydra("train", "train", [f"experiment={experiment}"] + ([f"model.size={size}"] if size == 64 else []))
    params = cfg.hydra.sweeper.params
    assert (params.renderer, params.brush, params.seed) == SWEEPS[experiment]
    assert cfg.hydra.sweep.dir.startswith(f"multirun/{experiment}/")
    assert cfg.trainer.max_time is None  # runs end on their step or epoch count, never on wall-clock
    if experiment.endswith("_paper"):
        assert (cfg.model.size, cfg.data.epoch_size, cfg.trainer.max_epochs, cfg.trainer.accelerator) == (128, 50_000, 400, "gpu")
        assert cfg.model.optimizer.lr == 2e-4  # the paper's, for every renderer
    else:  # one budget for every renderer, in steps, small enough for a CPU
        assert (cfg.model.size, cfg.trainer.max_steps, cfg.data.batch_size, cfg.trainer.accelerator) == (size, 1500, 64, "cpu")
        assert cfg.hydra.sweep.dir.endswith(f"_{size}px")  # a study's dir says its scale

    cfg = compose_with_hydra("train", "train", [f"experiment={experiment}", "renderer=dual", "brush=watercolor",
                                                 *TINY_TRAIN, f"output_dir={tmp_path}"])
    metrics = train(cfg)
    assert (metrics["steps"], metrics["status"]) == (2, "completed")
    assert json.loads((tmp_path / "metrics.json").read_text())["val/psnr"] == metrics["val/psnr"]


@pytest.fixture
def paint_experiment(tmp_path):
    def compose_paint(experiment: str, *overrides: str):
        return compose_with_hydra("paint", "paint", [f"experiment={experiment}", f"output_dir={tmp_path}", *overrides])

    return compose_paint


@pytest.mark.parametrize("size", [32, 64])
@pytest.mark.parametrize("renderer", COMPARISON.split(",") + ["dual_raster", "dual_shading", "dual_silhouette"])
def test_one_comparison_job_trains_with_its_renderers_own_rate_at_its_size(renderer, size):
    register_configs()
    cfg = compose_with_hydra("train", "train", ["experiment=renderer_comparison", f"renderer={renderer}", f"model.size={size}"])
    assert cfg.model.optimizer.lr == cfg.lr_by_renderer[f"{size}px"].get(renderer, cfg.lr_by_renderer[f"{size}px"]["dual"])
    assert set(cfg.lr_by_renderer[f"{size}px"]) == set(SWEEPS["renderer_lr"][0].split(","))  # every rate comes from the study
    lr_study = compose_with_hydra("train", "train", ["experiment=renderer_lr", f"renderer={renderer}", "model.optimizer.lr=3e-4"])
    assert lr_study.model.optimizer.lr == 3e-4 and lr_study.trainer.max_steps == cfg.trainer.max_steps


def test_ot_push_moves_a_stroke_and_records_position_error(paint_experiment, tmp_path):
    cfg = paint_experiment("ot_push", "loss=l1_ot", "task.steps=2", "task.trials=2")
    assert (cfg.hydra.sweeper.params.loss, cfg.brush.name) == ("l1,l1_ot", "tape")
    metrics = instantiate(cfg.task)(cfg)
    assert json.loads((tmp_path / "metrics.json").read_text()) == metrics
    assert metrics["position_error_start"] == pytest.approx(0.45, abs=0.02)  # the configured gap
    assert metrics["position_error"] != metrics["position_error_start"]  # it moved
    assert (tmp_path / "push.png").is_file() and list(tmp_path.glob("events.*"))


def test_ot_digits_starts_strokes_off_the_ink_and_scores_it_with_spread(paint_experiment, tmp_path):
    cfg = paint_experiment("ot_digits", "loss=l1", "task.steps=2", "task.count=3", "strokes=2")
    assert (cfg.hydra.sweeper.params.loss, cfg.brush.name, cfg.background, cfg.task.count) == ("l1,l1_ot", "markerpen", "black", 3)
    metrics = instantiate(cfg.task)(cfg)
    assert {"psnr", "psnr_std", "iou", "iou_std", "seconds"} <= metrics.keys() and 0 <= metrics["iou"] <= 1
    assert metrics["iou_start"] == 0  # no start stroke touches its digit's ink
    per_digit = json.loads((tmp_path / "digits.json").read_text())
    assert len(per_digit["psnr"]) == len(per_digit["iou"]) == 3
    assert metrics["strokes"] == 2 and (tmp_path / "digits.png").is_file()


def test_off_ink_starts_keep_their_distance_from_the_ink():
    from nsp.brushes import get_brush
    from nsp.engine import render
    from nsp.experiments.ot import digit_targets, off_ink_starts

    brush = get_brush("markerpen")
    mask, _ = digit_targets(20, 64, torch.zeros(3))
    x = off_ink_starts(brush, mask, 4, 0.08, (0.1, 0.2), 0.05, torch.Generator().manual_seed(0))
    coverage = render(brush, x, 64)[1].view(20, 4, 64, 64)
    assert float((coverage * (mask > 0.05)).sum()) == 0  # not one pixel of a start stroke on its digit
    with pytest.raises(ValueError, match="brush=tape"):
        off_ink_starts(get_brush("tape"), mask, 4, 0.08, (0.1, 0.2), 0.05, torch.Generator())



@pytest.mark.parametrize("root, name", [("train", "train"), ("paint", "paint")])
@pytest.mark.parametrize("launcher, target", [("joblib", "JoblibLauncher"), ("slurm", "SlurmLauncher")])
def test_launchers_compose(root, name, launcher, target):
    register_configs()
    cfg = compose_with_hydra(root, name, [f"hydra/launcher={launcher}"])
    assert cfg.hydra.launcher._target_.endswith(target)
    if launcher == "slurm":
        assert cfg.hydra.launcher.gpus_per_node == 1 and cfg.hydra.launcher.timeout_min > 0


@pytest.fixture(scope="module")
def trained_sweep(tmp_path_factory) -> Path:
    """A finished training sweep of two tiny DCGAN-G renderers of tape (seeds 0 and 1)."""
    register_configs()
    sweep = tmp_path_factory.mktemp("renderer_comparison")
    for seed in (0, 1):
        train(compose_with_hydra("train", "train", ["renderer=dcgan", "brush=tape", *TINY_TRAIN, "data.num_workers=0",
                                                    f"seed={seed}", f"output_dir={sweep / f'{seed}_dcgan_tape_seed{seed}'}"]))
    return sweep


def test_renderer_painting_paints_through_every_checkpoint_and_the_analytic_renderer(trained_sweep, tmp_path, capsys,
                                                                                      monkeypatch):
    from test_catalogue import run_cli

    from nsp.reporting import write_report

    code, err = run_cli("nsp.paint", ["-m", "experiment=renderer_painting", f"task.sweep={trained_sweep}", "image=astronaut,chelsea",
                                      "strokes=3,6", "work_size=32", "animation_size=32", "hydra/launcher=basic",
                                      f"hydra.sweep.dir={tmp_path}"], capsys, monkeypatch)
    assert code == 0, err
    jobs = [json.loads(p.read_text()) for p in sorted(tmp_path.glob("*/metrics.json"))]
    assert len(jobs) == 4 * 2 * 2  # (2 checkpoints + analytic with their 2 seeds) × 2 photos × 2 budgets
    assert {"0_dcgan_tape_seed0_chelsea_6", "analytic_tape_seed1_astronaut_3"} <= {p.name for p in tmp_path.iterdir()}
    trained = {seed: json.loads((trained_sweep / f"{seed}_dcgan_tape_seed{seed}" / "metrics.json").read_text()) for seed in (0, 1)}
    for job in jobs:
        assert job["brush"] == "tape" and 0 < job["ssim"] < 1 and job["strokes"] in (3, 6)
        if job["renderer"] == "dcgan":
            assert job["renderer_psnr"] == trained[job["seed"]]["test/psnr"]
        else:
            assert job["renderer"] == "analytic" and "renderer_psnr" not in job and job["seed"] in (0, 1)
    strokes = [(tmp_path / f"analytic_tape_seed{seed}_chelsea_6" / "strokes.json").read_text() for seed in (0, 1)]
    assert strokes[0] != strokes[1]  # each seed paints a painting of its own
    report = write_report(tmp_path)
    text = report[0].read_text()
    table = text.split("## Painting through each renderer: tape")[1]
    assert "| renderer | test PSNR | PSNR @3 | SSIM @3 | seconds @3 | PSNR @6 | SSIM @6 | seconds @6 |" in table
    rows = [line for line in table.splitlines() if line.startswith(("| dcgan", "| analytic"))]
    mean = sum(trained[s]["test/psnr"] for s in (0, 1)) / 2
    assert rows[0].startswith(f"| dcgan | {mean:.2f} ± ") and rows[1].startswith("| analytic | — | ")
    margin = text.split("The analytic renderer's margin in painting PSNR (dB), tape")[1]
    assert "| analytic minus | @3 | @6 |" in margin and " p=" in margin.split("| dcgan |")[1].splitlines()[0]
    assert (tmp_path / "renderer_vs_painting.png").read_bytes()[:4] == b"\x89PNG"


def test_renderer_painting_of_a_dir_without_trained_renderers_is_one_line(tmp_path, capsys, monkeypatch):
    from test_catalogue import run_cli

    code, err = run_cli("nsp.paint", ["-m", "experiment=renderer_painting", f"task.sweep={tmp_path}",
                                      f"hydra.sweep.dir={tmp_path / 'out'}"], capsys, monkeypatch)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and f"task.sweep={tmp_path} holds no completed training job" in lines[0], err
