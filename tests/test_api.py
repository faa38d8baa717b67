"""nsp from Python (nsp.api): the README's example runs as written; a painting from an array, with
the command's defaults and checks; Ctrl-C returns what was painted; a renderer trains, then paints.
Photos of every dtype and layout, what is not one, render sizes, clamped pixels, a folder holding
another painting, saves each file whole, a painting's repr and its picture in a notebook."""
import errno
import io
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
import torch
from PIL import Image

from nsp import api
from nsp.engine import memory
from nsp.errors import BadInput, RunFailed
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


def red_right_half(dtype=np.uint8, white=255) -> np.ndarray:
    """A (40, 60, 3) photo: black on the left, red on the right, in ``dtype`` of white ``white``."""
    photo = np.zeros((40, 60, 3), dtype)
    photo[:, 30:, 0] = white * 200 // 255
    return photo


def assert_red_on_the_right(painting: api.Painting) -> None:
    image = painting.render(60).astype(int)
    assert image[:, 45:, 0].mean() > image[:, 45:, 1].mean() + 60 and image[:, :15].mean() < 100  # not white


@pytest.fixture(scope="module")
def painted(tmp_path_factory) -> api.Painting:
    """A painting of an (H, W, 3) uint8 tensor, the issue's ``torch.from_numpy(coffee)``."""
    return api.paint(torch.from_numpy(red_right_half()), out=tmp_path_factory.mktemp("api") / "run", **SMALL)


def test_a_uint8_tensor_is_painted_as_its_array(painted):
    assert len(painted.strokes.strokes) == 12
    assert_red_on_the_right(painted)


def test_what_is_not_a_picture_is_one_line_naming_what_is_and_leaves_no_folder(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where the temporary folders would be
    for image, words in [(None, "image=None (NoneType) is not a picture; expected a path, a built-in photo's name "
                                "(astronaut, chelsea, coffee, rocket, flower, china), a PIL image, or a numpy array or "
                                "torch tensor shaped (H, W), (H, W, C), (C, H, W) or (1, C, H, W)"),
                         (123, "image=123 (int) is not a picture; expected a path"),
                         (red_right_half(np.float64), "image: float64 values from 0 to 200; floats are read in [0, 1]"),
                         (red_right_half(np.int32, 65535), "image: int32 values from 0 to 51400, outside 0–255")]:
        with pytest.raises(BadInput) as refused:
            api.paint(image, **SMALL)
        assert str(refused.value).startswith(words) and "\n" not in str(refused.value), str(refused.value)
    with pytest.raises(BadInput, match="strokes=0: expected a positive number"):  # refused once its folder was made
        api.paint("astronaut", **{**SMALL, "strokes": 0})
    with pytest.raises(BadInput, match="brush=oil: no such brush"):
        api.paint("astronaut", brush="oil")
    assert not list(tmp_path.iterdir())  # no nsp-paint-* left


@pytest.mark.parametrize("size", ["big", 0, 15, -1024, 2.5, True, None, 10**400, 10**9 + 1])
def test_a_render_size_that_is_not_one_is_refused_naming_the_sizes_there_are(painted, size):
    shown = "an integer of over 39 digits" if size == 10**400 else repr(size)
    with pytest.raises(BadInput, match=re.escape(f"size={shown}: expected a whole number of pixels from 16 to 1000000000")):
        painted.render(size)


def test_a_render_past_the_memory_is_refused_before_it_starts_and_a_numpy_size_renders(painted, monkeypatch):
    assert painted.render(np.int64(16)).shape == (11, 16, 3)
    monkeypatch.setattr(memory, "available_bytes", lambda: 2 * 10**9)
    with pytest.raises(memory.MemoryLimit, match=r"^size=20000: a 20000×13438 render needs about [\d.]+ GB, 2.0 GB is "
                                                  r"available; the largest that fits is about size=\d+$"):
        painted.render(20000)


def test_pixels_past_white_stay_white_and_past_black_black(painted, monkeypatch):
    def engine(brush, strokes, height, width, background):  # as the engine may return: up to 1.012, below 0
        canvas = torch.full((3, height, width), 1.012)
        canvas[:, :, 0] = -0.004
        canvas[:, :, 1] = 0.5
        return canvas

    monkeypatch.setattr(api, "paint_canvas", engine)
    image = painted.render(64)
    assert (image[:, 2:] == 255).all() and (image[:, 0] == 0).all() and (image[:, 1] == 128).all()


def test_a_painting_shows_itself_in_one_line_and_as_a_picture(painted):
    psnr = painted.metrics["psnr"]
    assert repr(painted) == f"<Painting: 12 oilpaint strokes, 64×43 px, PSNR {psnr:.2f} dB>"
    assert repr(api.load(painted.folder / "strokes.json", {})) == "<Painting: 12 oilpaint strokes, 64×43 px>"
    with Image.open(io.BytesIO(painted._repr_png_())) as shown:
        assert shown.format == "PNG" and shown.size == (512, 344)  # the canvas 64×43
        assert np.array_equal(np.asarray(shown.convert("RGB")), painted.render(512))


def test_a_folder_holding_another_painting_is_refused_unless_overwrite(painted, tmp_path):
    other = tmp_path / "other"
    other.mkdir()
    for name in ("final.png", "strokes.json", "style.png"):
        (other / name).write_text(f"another painting's {name}")
    with pytest.raises(BadInput, match=re.escape(f"folder={other} holds another painting (final.png, strokes.json, "
                                                 "style.png); name another folder, or pass overwrite=True to replace it")):
        painted.save(other)
    assert (other / "final.png").read_text() == "another painting's final.png"
    assert painted.save(other, overwrite=True) == other
    assert sorted(p.name for p in other.iterdir()) == sorted(p.name for p in painted.folder.iterdir() if p.name in api.FILES)
    assert all((other / n).read_bytes() == (painted.folder / n).read_bytes() for n in ("final.png", "strokes.json"))
    assert painted.save(painted.folder) == painted.folder  # its own: nothing to copy
    (tmp_path / "lone").mkdir()
    shutil.copy(painted.folder / "strokes.json", tmp_path / "lone" / "mine.json")  # a stroke file of another name
    saved = api.load(tmp_path / "lone" / "mine.json").save(tmp_path / "saved")
    assert [p.name for p in saved.iterdir()] == ["strokes.json"]
    assert torch.equal(api.load(saved / "strokes.json").strokes.strokes, painted.strokes.strokes)
    (tmp_path / "file").write_text("notes")
    with pytest.raises(BadInput, match=f"folder={tmp_path / 'file'} is a file; expected a folder"):
        painted.save(tmp_path / "file")
    with pytest.raises(BadInput, match=re.escape(f"out={painted.folder} holds another painting (final.png")):
        api.paint(red_right_half(), out=painted.folder, **SMALL)  # before any work


def test_a_save_onto_a_full_disk_keeps_each_file_whole_in_one_line(painted, tmp_path, monkeypatch):
    saved = painted.save(tmp_path / "saved")
    copy = shutil.copy2

    def full(source, target):
        if Path(source).name == "final.png":
            Path(target).write_bytes(Path(source).read_bytes()[:100])  # as far as the disk had room
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(target))
        return copy(source, target)

    (saved / "final.png").write_bytes(b"the good one")
    monkeypatch.setattr(shutil, "copy2", full)
    with pytest.raises(RunFailed) as refused:
        painted.save(saved, overwrite=True)
    assert str(refused.value) == (f"folder={saved}: could not save the painting there (No space left on device); "
                                  "each file there is whole, the old one or the new")
    assert (saved / "final.png").read_bytes() == b"the good one" and not list(saved.glob(".*"))


def test_paint_overwrites_a_painting_when_told_and_a_16_bit_photo_is_not_white(painted, tmp_path):
    out = shutil.copytree(painted.folder, tmp_path / "run")
    (out / "style.png").write_bytes(b"the other painting's style")
    painting = api.paint(red_right_half(np.uint16, 65535), out=out, overwrite=True, seed=1, **SMALL)
    assert_red_on_the_right(painting)
    assert not (out / "style.png").exists() and (out / "metrics.json").read_bytes() != (painted.folder / "metrics.json").read_bytes()
    assert painting.strokes.strokes.ne(painted.strokes.strokes).any()  # seed 1's, not the copy's
