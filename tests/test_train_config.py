"""``python -m nsp.train`` configs: every file composes; bad overrides fail at compose time, saying why."""
import subprocess
import sys
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.errors import HydraException
from omegaconf import OmegaConf

from nsp.renderers import build
from nsp.cli import did_you_mean
from nsp.training.schema import key_tree, register_configs

CONF = Path(__file__).parents[1] / "conf" / "train"
CHOICES = [f"{group.name}={f.stem}" for group in sorted(CONF.iterdir()) if group.is_dir() for f in sorted(group.glob("*.yaml"))]


def compose_train(*overrides: str):
    register_configs()
    with initialize_config_dir(str(CONF), version_base="1.3"):
        return compose("train", overrides=list(overrides))


def run_cli(*overrides: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nsp.train", *overrides], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("choice", CHOICES)
def test_every_config_file_composes_and_resolves(choice):
    cfg = compose_train(choice, "output_dir=/unused")
    resolved = OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)
    assert resolved["renderer"]["size"] == resolved["model"]["size"]


def test_default_is_the_cpu_preset_of_dual_watercolor():
    cfg = compose_train()
    assert (cfg.renderer._target_, cfg.brush.name, cfg.model.size) == ("nsp.renderers.DualPathway", "watercolor", 32)
    assert cfg.trainer.max_steps > 0 and cfg.trainer.accelerator == "cpu"


def test_paper_preset_is_the_papers_training():
    cfg = compose_train("preset=paper", "trainer=gpu")
    assert (cfg.model.size, cfg.model.channel_mult, cfg.data.batch_size, cfg.data.epoch_size) == (128, 1.0, 64, 50_000)
    assert cfg.trainer.max_epochs == 400 and cfg.trainer.accelerator == "gpu"
    assert (cfg.model.optimizer.lr, list(cfg.model.optimizer.betas)) == (2e-4, [0.9, 0.999])
    assert (cfg.model.scheduler.step_size, cfg.model.scheduler.gamma, cfg.model.scheduler_interval) == (100, 0.1, "epoch")


def test_renderer_config_builds_the_renderer_for_the_brush():
    cfg = compose_train("renderer=dual_shading", "brush=markerpen", "model.channel_mult=0.125")
    renderer = build(OmegaConf.to_container(cfg.renderer, resolve=True), cfg.brush.name)
    assert renderer.rasterization is None and renderer.size == 32


@pytest.mark.parametrize(
    "override, suggestion",
    [("trainer.max_epoch=3", "trainer.max_epochs"), ("data.batch_sise=2", "data.batch_size"), ("renderer.channel_mlt=1", "renderer.channel_mult")],
)
def test_misspelt_key_gets_did_you_mean(override, suggestion):
    with pytest.raises(HydraException) as error:
        compose_train(override)
    assert f"Did you mean '{suggestion}'?" in did_you_mean(str(error.value), key_tree())


def test_a_key_near_none_and_a_deliberately_added_key_get_no_hint():
    with pytest.raises(HydraException) as error:
        compose_train("zzzz=3")
    assert did_you_mean(str(error.value), key_tree()) is None
    assert compose_train("+trainer.fast_dev_run=true").trainer.fast_dev_run is True
