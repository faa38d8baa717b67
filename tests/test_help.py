"""``--help`` of every command: what it does, examples, its main keys and the groups to pick from,
shown by Hydra from the command's config without importing torch (how fast: benchmarks/help.py)."""
import re
import subprocess
import sys

import pytest
from omegaconf import OmegaConf

from nsp.config import BRUSH_NAMES, CONF

COMMANDS = ("paint", "train", "render", "report")
HEAVY = ("torch", "pytorch_lightning", "lightning", "tensorboard", "matplotlib")


def imported(*args: str) -> tuple[subprocess.CompletedProcess, set[str]]:
    """``python -X importtime -m …``: the finished process and the top-level packages it imported."""
    result = subprocess.run([sys.executable, "-X", "importtime", "-m", *args], capture_output=True, text=True)
    modules = {line.rsplit("|", 1)[-1].strip().split(".")[0] for line in result.stderr.splitlines()
               if line.startswith("import time:")}
    return result, modules


def help_of(name: str, *overrides: str) -> str:
    result = subprocess.run([sys.executable, "-m", f"nsp.{name}", *overrides, "--help"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


@pytest.mark.parametrize("name", COMMANDS)
def test_help_says_what_the_command_does_without_importing_torch(name):
    result, modules = imported(f"nsp.{name}", "--help")
    assert result.returncode == 0, result.stderr[-2000:]
    assert not modules & set(HEAVY), modules & set(HEAVY)
    assert result.stdout.startswith(f"usage: python -m nsp.{name}")
    assert "examples:" in result.stdout and result.stdout.count(f"python -m nsp.{name}") >= 4


@pytest.mark.parametrize("name", ["paint", "train", "render"])
def test_help_lists_main_keys_that_exist_and_every_group_a_user_picks(name):
    module = __import__(f"nsp.{name}", fromlist=["schema"])
    tree, text = OmegaConf.to_container(OmegaConf.structured(module.schema())), help_of(name)
    keys = re.findall(r"^  ([a-z_.]+)=[A-Z]+ ", text.split("main keys")[1].split("config groups")[0], re.M)
    assert len(keys) >= 5
    for key in keys:
        node = tree
        for part in key.split(".") if not key.startswith("hydra.") else []:
            assert part in node, key
            node = node[part]
    listed = set(re.findall(r"^  ([a-z_]+) {2,}\S", text.split("config groups")[1], re.M))
    assert listed == {p.name for p in (CONF / name).iterdir() if p.is_dir() and p.name != "hydra"} | {"brush"}


def test_the_defaults_help_shows_are_the_runs_own():
    train = help_of("train")
    assert "cosine*" in train and "step*" not in train  # preset=cpu's, over train.yaml's
    assert "step*" in help_of("train", "preset=paper") and "(128)" in help_of("train", "preset=paper")
    paint = help_of("paint", "strokes=7", "brush=tape")
    assert "how many strokes (7)" in paint and "tape*" in paint and "oilpaint*" not in paint


def test_the_brush_names_help_reads_without_importing_torch_are_the_real_ones():
    from nsp.brushes import BRUSHES

    assert BRUSH_NAMES == tuple(BRUSHES)


def test_a_bad_value_is_refused_before_the_first_line_and_printed_configs_stay_clean():
    result = subprocess.run([sys.executable, "-m", "nsp.paint", "strokes=abc"], capture_output=True, text=True)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.strip().splitlines() == ["error: Error merging override strokes=abc: Value 'abc' of type 'str' "
                                                  "could not be converted to Integer"]
    result = subprocess.run([sys.executable, "-m", "nsp.paint", "strokes=7", "--cfg", "job"], capture_output=True, text=True)
    assert result.returncode == 0 and OmegaConf.create(result.stdout).strokes == 7
