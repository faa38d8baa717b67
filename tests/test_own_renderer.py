"""A renderer of one's own (docs/add-a-renderer.md, run as written there): trained, reported and painted
without an edit to nsp; a checkpoint naming a class that is not a renderer is refused in one line."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from nsp.errors import BadInput
from nsp.renderers.checkpoint import load_renderer

ROOT = Path(__file__).resolve().parents[1]
PAGE = (ROOT / "docs" / "add-a-renderer.md").read_text()
FAST = ["data.val_size=64", "data.test_size=64", "data.num_workers=0", "trainer.enable_progress_bar=false"]


def example(folder: Path) -> dict[str, str]:
    """The page's renderer module and YAML written into ``folder``; its two command lines, by command."""
    python, yaml = re.findall(r"```(?:python|yaml)\n(.*?)```", PAGE, re.S)
    (folder / "conf" / "renderer").mkdir(parents=True)
    (folder / "tiny_renderer.py").write_text(python)
    (folder / "conf" / "renderer" / "tiny.yaml").write_text(yaml)
    lines = re.search(r"```\n(PYTHONPATH=DIR python -m nsp.train .*?)```", PAGE, re.S)[1].strip().splitlines()
    return {line.split()[3]: line.replace("DIR", str(folder)) for line in lines}


def run(line: str, *extra: str, cwd: Path) -> subprocess.CompletedProcess:
    """A command line of the page as a shell would run it (its quotes, its PYTHONPATH=…), in ``cwd``."""
    command = line.replace("python -m", f"{sys.executable} -m") + " " + " ".join(extra)
    return subprocess.run(["bash", "-c", command], cwd=cwd, capture_output=True, text=True, timeout=600)


def test_a_renderer_of_ones_own_trains_and_paints_as_the_docs_say(tmp_path):
    lines = example(tmp_path)
    trained = run(lines["nsp.train"], *FAST, cwd=ROOT)  # the checkout's dir: nothing of tmp_path on the path but PYTHONPATH
    assert trained.returncode == 0, trained.stderr
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["renderer"] == "tiny" and metrics["status"] == "completed" and metrics["test/psnr"] > 0
    saved = torch.load(tmp_path / "run" / "checkpoints" / "last.ckpt", weights_only=True)["hyper_parameters"]
    assert saved["renderer"]["_target_"] == "tiny_renderer.Tiny" and saved["brush"] == "tape"
    painted = run(lines["nsp.paint"], "strokes=6", "work_size=32", "render_size=48", "animation_size=32",
                  "progress=false", f"hydra.run.dir={tmp_path / 'painting'}", cwd=ROOT)
    assert painted.returncode == 0, painted.stderr
    assert painted.stdout.strip().splitlines()[-1].startswith("painted 6 tape strokes")


def test_a_checkpoint_whose_class_is_not_a_renderer_is_refused_in_one_line(tmp_path):
    lines = example(tmp_path)
    assert run(lines["nsp.train"], *FAST, "trainer.max_steps=2", cwd=ROOT).returncode == 0
    path = tmp_path / "run" / "checkpoints" / "last.ckpt"
    checkpoint = torch.load(path, weights_only=True)
    for target, why in (("collections.OrderedDict", "not a torch.nn.Module subclass"), ("no_such_module.Tiny", "No module")):
        checkpoint["hyper_parameters"]["renderer"]["_target_"] = target
        torch.save(checkpoint, tmp_path / "other.ckpt")
        with pytest.raises(BadInput, match=why) as error:
            load_renderer(tmp_path / "other.ckpt")
        assert "\n" not in str(error.value) and target in str(error.value)
