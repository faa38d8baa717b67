"""``--help`` of every command: what it does, examples, its main keys and the groups to pick from,
shown without importing torch (how fast: benchmarks/help.py)."""
import importlib
import subprocess
import sys

import pytest
from omegaconf import OmegaConf

from nsp import cli
from nsp.config import BRUSH_NAMES, CONF

COMMANDS = ("paint", "train", "render", "report")
HEAVY = ("torch", "pytorch_lightning", "lightning", "tensorboard", "matplotlib")


def imported(*args: str) -> tuple[subprocess.CompletedProcess, set[str]]:
    """``python -X importtime -m …``: the finished process and the top-level packages it imported."""
    result = subprocess.run([sys.executable, "-X", "importtime", "-m", *args], capture_output=True, text=True)
    modules = {line.rsplit("|", 1)[-1].strip().split(".")[0] for line in result.stderr.splitlines()
               if line.startswith("import time:")}
    return result, modules


@pytest.mark.parametrize("name", COMMANDS)
def test_help_says_what_the_command_does_without_importing_torch(name):
    result, modules = imported(f"nsp.{name}", "--help")
    assert result.returncode == 0, result.stderr[-2000:]
    assert not modules & set(HEAVY), modules & set(HEAVY)
    assert result.stdout.startswith(f"usage: python -m nsp.{name}")
    assert "examples:" in result.stdout and result.stdout.count(f"python -m nsp.{name}") >= 4


@pytest.mark.parametrize("name", ["paint", "train", "render"])
def test_help_lists_main_keys_that_exist_and_every_group_a_user_picks(name):
    module = importlib.import_module(f"nsp.{name}")
    usage, tree = module.USAGE, OmegaConf.to_container(OmegaConf.structured(module.schema()))
    text = cli.help_text(name, usage)
    assert usage.summary.split()[0] in text and "task: null" not in text and "schema" not in text
    for key in usage.keys:
        node = tree
        for part in key.split("=")[0].split(".") if not key.startswith("hydra.") else []:
            assert part in node, key
            node = node[part]
    groups = {p.name for p in (CONF / name).iterdir() if p.is_dir() and p.name != "hydra"} | {"brush"}
    assert set(usage.groups) == groups


def test_the_defaults_help_shows_follow_the_preset():
    text = cli.help_text("train", importlib.import_module("nsp.train").USAGE)
    assert "cosine*" in text and "step*" not in text  # preset=cpu overrides train.yaml's lr_schedule
    assert "oilpaint*" in cli.help_text("paint", importlib.import_module("nsp.paint").USAGE)


def test_the_brush_names_help_reads_without_importing_torch_are_the_real_ones():
    from nsp.brushes import BRUSHES

    assert BRUSH_NAMES == tuple(BRUSHES)


def test_the_first_line_says_what_will_be_painted_and_printed_configs_stay_clean():
    from nsp.paint import opening

    assert opening(["image=cat.jpg", "strokes=40", "brush=tape"]) == "painting cat.jpg with 40 tape strokes…"
    assert opening([]) == "painting astronaut with 500 oilpaint strokes…"
    assert opening(["strokes=1"]) == "painting astronaut with 1 oilpaint stroke…"
    assert opening(["-m", "seed=0,1"]).startswith("starting python -m nsp.paint -m seed=0,1")
    assert opening(["experiment=ot_push"]).startswith("starting")
    result = subprocess.run([sys.executable, "-m", "nsp.paint", "strokes=7", "--cfg", "job"], capture_output=True, text=True)
    assert result.returncode == 0 and OmegaConf.create(result.stdout).strokes == 7
