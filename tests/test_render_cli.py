"""`python -m nsp.render`: PNG from the engine, SVG a browser-grade renderer draws alike, GIF in order."""
import io
import json
import os
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest
import resvg_py as resvg  # a dev dependency: SVGs drawn as a browser draws them
import torch
from PIL import Image

from omegaconf import OmegaConf

from nsp.brushes import BRUSHES
from nsp.engine import memory
from nsp.files import atomic_path
from nsp.io.strokes import StrokeFile, load_strokes, save_strokes
from nsp.render import RenderConfig, render


def run(*args):
    return subprocess.run([sys.executable, "-m", "nsp.render", *args], capture_output=True, text=True)


@pytest.fixture
def painting(tmp_path, generator):
    def make(name, n=12):
        brush = BRUSHES[name]
        x = brush.sample(n, generator)
        x[:, [i for i, k in enumerate(brush.kinds) if k == "size"]] *= 0.4
        path = tmp_path / f"{name}.json"
        save_strokes(path, StrokeFile(BRUSHES[name], x, 80, 120, "#203040"))
        return path

    return make


def read(path):
    return np.asarray(Image.open(path).convert("RGB")).astype(np.float64)


def psnr(a, b):
    return 10 * np.log10(255**2 / ((a - b) ** 2).mean())


@pytest.mark.parametrize("name", list(BRUSHES))
def test_svg_renders_like_the_png(name, painting, tmp_path):
    from nsp.io.export import write_painting

    p = load_strokes(painting(name))
    write_painting(tmp_path / "a.png", p.brush, p.strokes, 80, 120, p.background)
    write_painting(tmp_path / "a.svg", p.brush, p.strokes, 80, 120, p.background)
    drawn = np.asarray(Image.open(io.BytesIO(bytes(resvg.svg_to_bytes(svg_path=str(tmp_path / "a.svg"))))).convert("RGB"))
    assert drawn.shape == (80, 120, 3)
    assert psnr(drawn.astype(np.float64), read(tmp_path / "a.png")) > 24


def test_png_and_gif_from_the_command_line(painting, tmp_path):
    path = painting("watercolor")
    result = run(f"strokes={path}", "size=240", "background=white", f"out={tmp_path / 'w.png'}")
    assert result.returncode == 0, result.stderr
    image = read(tmp_path / "w.png")
    assert image.shape == (160, 240, 3)  # long side 240, the file's 3:2 aspect kept
    assert run(f"strokes={path}", "size=120", f"out={tmp_path / 'w.gif'}").returncode == 0
    frames = iio.imread(tmp_path / "w.gif", index=None)
    assert len(frames) == 13  # the empty canvas, then one stroke more per frame
    assert np.all(frames[0][..., :3] == [0x20, 0x30, 0x40])
    assert not np.array_equal(frames[-1], frames[-2])


def test_reference_npz_renders_with_brush(tmp_path):
    np.savez(tmp_path / "r.npz", x_ctt=np.array([[[0.5, 0.5, 0.5, 0.25, 0.0]]]), x_color=np.array([[[1.0, 0, 0]]]),
             x_alpha=np.array([[[1.0]]]))
    result = run(f"strokes={tmp_path / 'r.npz'}", "brush=tape", "size=64", "background=black", f"out={tmp_path / 'r.png'}")
    assert result.returncode == 0, result.stderr
    image = read(tmp_path / "r.png")
    assert image[32, 32, 0] == 255 and image[0, 0].sum() == 0


def refused(result, words, folder):
    """The command ended as a bad input should: exit 2, one ``error:`` line naming the value, and
    nothing written in ``folder`` (no output file, no temporary one)."""
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1, result.stderr
    assert words in result.stderr
    assert not [p.name for p in folder.rglob("*") if p.is_file() and p.suffix in (".png", ".svg", ".gif")]


def test_non_finite_reference_strokes_are_refused(tmp_path):
    ctt = np.array([[[0.5, 0.5, 0.5, 0.25, 0.0], [np.nan, 0.5, 0.5, 0.25, 0.0], [0.5, np.inf, 0.5, 0.25, 0.0]]])
    np.savez(tmp_path / "r.npz", x_ctt=ctt, x_color=np.ones((1, 3, 3)), x_alpha=np.ones((1, 3, 1)))
    result = run(f"strokes={tmp_path / 'r.npz'}", "brush=tape", "size=64", f"out={tmp_path / 'r.png'}")
    refused(result, f"strokes={tmp_path / 'r.npz'}: 2 of 3 strokes hold NaN or infinite values", tmp_path)


def test_non_finite_json_strokes_are_refused(painting, tmp_path):
    path = painting("tape")
    data = json.loads(path.read_text())
    data["strokes"][3]["x"] = float("nan")  # json writes NaN, and reads it back
    path.write_text(json.dumps(data))
    result = run(f"strokes={path}", "size=64", f"out={tmp_path / 'o.png'}")
    refused(result, "1 of 12 strokes have a parameter that is not a finite number in [0, 1], got nan (x of stroke 3)",
            tmp_path)


@pytest.mark.parametrize("extension", [".png", ".svg", ".gif"])
def test_an_empty_painting_renders_its_canvas(extension, tmp_path):
    # What a painting interrupted before its first stroke leaves.
    save_strokes(tmp_path / "e.json", StrokeFile(BRUSHES["watercolor"], torch.zeros(0, 15), 80, 120, "#203040"))
    result = run(f"strokes={tmp_path / 'e.json'}", "size=90", f"out={tmp_path / ('e' + extension)}")
    assert result.returncode == 0, result.stderr
    if extension == ".svg":
        image = Image.open(io.BytesIO(bytes(resvg.svg_to_bytes(svg_path=str(tmp_path / "e.svg")))))
    else:
        image = Image.open(tmp_path / ("e" + extension))
    assert np.all(np.asarray(image.convert("RGB")) == np.full((60, 90, 3), [0x20, 0x30, 0x40]))


@pytest.mark.parametrize(
    "content, words",
    [
        ("[1, 2]", " is not an nsp stroke file (expected a JSON object with format 'nsp-strokes')"),
        ('{"format": "nsp-strokes", "version": 1, "brush": "tape", "strokes": []}',
         ' is malformed: expected "canvas": {"width": pixels, "height": pixels, "background": colour}'),
        ('{"format": "nsp-strokes", "version": 1, "brush": "tape", "strokes": {},'
         ' "canvas": {"width": 10, "height": 10, "background": "white"}}',
         ' is malformed: expected "strokes": a list of objects with x, y, w, h'),
        ('{"format": "nsp-strokes", "version": 1, "brush": 3}', ": unknown brush 3, expected one of: oilpaint"),
    ],
)
def test_a_malformed_stroke_file_is_one_line(content, words, tmp_path):
    (tmp_path / "bad.json").write_text(content)
    refused(run(f"strokes={tmp_path / 'bad.json'}", f"out={tmp_path / 'o.png'}"), f"bad.json{words}", tmp_path)


def test_out_must_be_a_file_in_a_folder_that_can_be_made(painting, tmp_path):
    path = painting("tape")
    (tmp_path / "taken.png").mkdir()
    result = run(f"strokes={path}", f"out={tmp_path / 'taken.png'}")
    refused(result, f"out={tmp_path / 'taken.png'} is a folder; expected a file path", tmp_path)
    (tmp_path / "file").write_text("")
    result = run(f"strokes={path}", f"out={tmp_path / 'file' / 'o.png'}")
    refused(result, f"out={tmp_path / 'file' / 'o.png'}: cannot make its folder {tmp_path / 'file'}", tmp_path)


def test_a_render_too_large_for_memory_is_refused_before_it_starts(painting, tmp_path):
    result = run(f"strokes={painting('tape')}", "size=10000000", f"out={tmp_path / 'huge.png'}")
    refused(result, "size=10000000: a 10000000×6666667 render needs about", tmp_path)


def test_the_memory_message_names_the_size_that_fits(painting, tmp_path, monkeypatch):
    monkeypatch.setattr(memory, "available_bytes", lambda: 2 * 10**9)
    cfg = OmegaConf.merge(OmegaConf.structured(RenderConfig), {"strokes": str(painting("tape")), "size": 20000,
                                                               "out": str(tmp_path / "o.png")})
    with pytest.raises(memory.MemoryLimit) as refusal:
        render(cfg)  # at once: nothing is allocated
    message = str(refusal.value)
    assert message.startswith("size=20000: a 20000×13333 render needs about ")
    assert "2.0 GB is available; the largest that fits is about size=" in message
    fits = int(message.rsplit("size=", 1)[1])
    p = load_strokes(cfg.strokes)
    height, width = p.size(fits)
    memory.check_canvas(height, width, "size", memory.stroke_cover(BRUSHES["tape"], p.strokes, height, width))
    assert not list(tmp_path.glob("*.png"))


def test_an_svg_is_checked_for_memory_where_it_holds_each_strokes_paint_as_an_image(painting, tmp_path, monkeypatch):
    monkeypatch.setattr(memory, "available_bytes", lambda: 2 * 10**9)

    def need(name, suffix):
        cfg = OmegaConf.merge(OmegaConf.structured(RenderConfig), {"strokes": str(painting(name)), "size": 16384,
                                                                   "out": str(tmp_path / f"{name}{suffix}")})
        with pytest.raises(memory.MemoryLimit) as refusal:
            render(cfg)
        message = str(refusal.value)
        assert message.startswith("size=16384: a 16384×10923 render needs about "), message
        return float(message.split("needs about ")[1].split(" GB")[0])

    assert need("oilpaint", ".svg") > need("oilpaint", ".png")  # the canvas, and every stroke's paint besides
    assert not (tmp_path / "oilpaint.svg").exists() and not (tmp_path / "oilpaint.png").exists()
    cfg = OmegaConf.merge(OmegaConf.structured(RenderConfig), {"strokes": str(painting("tape")), "size": 16384,
                                                               "out": str(tmp_path / "tape.svg")})
    assert 'width="16384" height="10923"' in render(cfg).read_text()  # vector elements: text at any size


def test_an_interrupted_write_leaves_the_old_file_and_no_other(tmp_path):
    (tmp_path / "o.png").write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_path(tmp_path / "o.png") as temporary:
        temporary.write_text("half")
        raise KeyboardInterrupt
    assert [p.name for p in tmp_path.iterdir()] == ["o.png"] and (tmp_path / "o.png").read_text() == "old"
    with atomic_path(tmp_path / "o.png") as temporary:
        temporary.write_text("new")
    assert [p.name for p in tmp_path.iterdir()] == ["o.png"] and (tmp_path / "o.png").read_text() == "new"


def test_a_write_removes_what_killed_writers_left_in_its_folder_and_nothing_else(tmp_path):
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead, alive = int(ended.stdout), os.getpid()
    left = [f".animation.{dead}-0123abcd.tmp.gif", f".strokes.{dead}-89abcdef.tmp"]  # a killed painting's
    kept = [f".final.{alive}-0123abcd.tmp.png", f".notes.{dead}.txt", "animation.gif"]  # a live writer's; not ours
    for name in left + kept:
        (tmp_path / name).write_text("x")
    with atomic_path(tmp_path / "final.png") as temporary:
        temporary.write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(kept + ["final.png"])


def test_device_auto_is_the_gpu_torch_sees_else_the_cpu(painting, tmp_path):
    from nsp.engine.device import resolve_device

    assert resolve_device("auto") == torch.device("cuda" if torch.cuda.is_available() else "cpu")
    assert resolve_device("CPU") == torch.device("cpu")
    path = painting("watercolor")
    for device in ("cpu", "auto"):
        render(OmegaConf.merge(OmegaConf.structured(RenderConfig), {"strokes": str(path), "out": str(tmp_path / f"{device}.png"),
                                                                     "size": 64, "device": device}))
    same = read(tmp_path / "cpu.png") - read(tmp_path / "auto.png")
    assert np.abs(same).max() <= (2 if torch.cuda.is_available() else 0)
