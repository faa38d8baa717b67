"""nsp from Python (nsp.api): the README's example runs as written; a painting from an array, with
the command's defaults and checks; Ctrl-C returns what was painted; a renderer trains, then paints."""
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from nsp import api
from nsp.errors import BadInput
from nsp.painter.painter import Painter

ROOT = Path(__file__).parents[1]
SMALL = {"strokes": 12, "work_size": 48, "render_size": 64, "animation_size": 32, "progress": False}


def test_the_readme_example_runs_as_written(tmp_path):
    code = re.search(r"## Painting from Python\n\n```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)[1]
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    psnr, shape = done.stdout.strip().splitlines()[-1].split(maxsplit=1)  # after the progress bar
    assert float(psnr) > 15 and shape.strip() == "(512, 512, 3)"
    assert {p.name for p in (tmp_path / "my_painting").iterdir()} == {
        "final.png", "strokes.json", "painting.svg", "animation.gif", "metrics.json"}


def test_an_array_is_painted_with_the_commands_defaults_and_a_bad_value_is_its_one_line(tmp_path):
    photo = np.zeros((40, 60, 3), np.uint8)
    photo[:, 30:] = (200, 40, 40)  # a red right half
    painting = api.paint(photo, out=tmp_path / "run", schedule={"polish": 1}, **SMALL)
    assert painting.strokes.brush.name == "oilpaint" and len(painting.strokes.strokes) == 12  # the default brush
    image = painting.render(60)
    assert image.shape == (40, 60, 3) and image.dtype == np.uint8
    assert image[:, 45:, 0].mean() > image[:, 45:, 1].mean() + 60  # red where the photo is
    assert painting.metrics["strokes"] == 12 and (tmp_path / "run" / "final.png").is_file()
    with pytest.raises(BadInput, match="strokes=0: expected a positive number"):
        api.paint("astronaut", out=tmp_path / "bad", **{**SMALL, "strokes": 0})
    with pytest.raises(BadInput, match="brush=oil: no such brush; expected one of: markerpen, oilpaint"):
        api.paint("astronaut", out=tmp_path / "bad", brush="oil")
    with pytest.raises(BadInput, match=re.escape("Could not override 'schedule.polis': no such key. Did you mean 'schedule.polish'?")):
        api.paint("astronaut", out=tmp_path / "bad", **{"schedule.polis": 3})


def test_ctrl_c_returns_what_was_painted(tmp_path, monkeypatch):
    paint = Painter.paint

    def interrupted(self, *args, **kwargs):
        self.callbacks.append(type("Stop", (), {"on_strokes": lambda *a: (_ for _ in ()).throw(KeyboardInterrupt),
                                                "on_step": lambda *a: None, "on_level": lambda *a: None})())
        return paint(self, *args, **kwargs)

    monkeypatch.setattr(Painter, "paint", interrupted)
    painting = api.paint("astronaut", out=tmp_path, brush="tape", **SMALL)
    assert 0 < len(painting.strokes.strokes) < 12 and painting.metrics == {}


def test_a_renderer_trains_from_python_and_paints(tmp_path):
    metrics = api.train(out=tmp_path, renderer="dcgan", brush="tape", model={"channel_mult": 0.125},
                        data={"batch_size": 8, "epoch_size": 16, "val_size": 8, "test_size": 8, "num_workers": 0},
                        trainer={"max_steps": 2, "enable_progress_bar": False})
    assert (metrics["renderer"], metrics["brush"], metrics["steps"], metrics["status"]) == ("dcgan", "tape", 2, "completed")
    checkpoint = tmp_path / "checkpoints" / "last.ckpt"
    painting = api.paint("astronaut", out=tmp_path / "painted", renderer="neural", **{"renderer.checkpoint": str(checkpoint)}, **SMALL)
    assert painting.strokes.brush.name == "tape"  # the checkpoint's own brush: brush= was not given
