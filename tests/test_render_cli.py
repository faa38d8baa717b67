"""`python -m nsp.render`: PNG from the engine, SVG a browser-grade renderer draws alike, GIF in order."""
import io
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest
import torch
from PIL import Image

from nsp.brushes import BRUSHES
from nsp.io.strokes import StrokeFile, save_strokes


def run(*args):
    return subprocess.run([sys.executable, "-m", "nsp.render", *args], capture_output=True, text=True)


@pytest.fixture
def painting(tmp_path, generator):
    def make(name, n=12):
        brush = BRUSHES[name]
        x = brush.sample(n, generator)
        x[:, [i for i, k in enumerate(brush.kinds) if k == "size"]] *= 0.4
        path = tmp_path / f"{name}.json"
        save_strokes(path, StrokeFile(name, x, 120, 80, "#203040"))
        return path

    return make


def read(path):
    return np.asarray(Image.open(path).convert("RGB")).astype(np.float64)


def psnr(a, b):
    return 10 * np.log10(255**2 / ((a - b) ** 2).mean())


@pytest.mark.parametrize("name", list(BRUSHES))
def test_svg_renders_like_the_png(name, painting, tmp_path):
    resvg = pytest.importorskip("resvg_py")
    from nsp.io.export import write_painting
    from nsp.io.strokes import load_strokes

    p = load_strokes(painting(name))
    write_painting(tmp_path / "a.png", p.brush, p.strokes, 120, 80, p.background)
    write_painting(tmp_path / "a.svg", p.brush, p.strokes, 120, 80, p.background)
    drawn = np.asarray(Image.open(io.BytesIO(bytes(resvg.svg_to_bytes(svg_path=str(tmp_path / "a.svg"))))).convert("RGB"))
    assert drawn.shape == (80, 120, 3)
    assert psnr(drawn.astype(np.float64), read(tmp_path / "a.png")) > 24


def test_png_and_gif_from_the_command_line(painting, tmp_path):
    path = painting("watercolor")
    result = run(f"strokes={path}", "size=240", "canvas=white", f"out={tmp_path / 'w.png'}")
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
    result = run(f"strokes={tmp_path / 'r.npz'}", "brush=tape", "size=64", "canvas=black", f"out={tmp_path / 'r.png'}")
    assert result.returncode == 0, result.stderr
    image = read(tmp_path / "r.png")
    assert image[32, 32, 0] == 255 and image[0, 0].sum() == 0


@pytest.mark.parametrize(
    "args, words",
    [
        (["out=x.bmp"], "unknown extension '.bmp', expected one of .png, .svg, .gif"),
        (["strokes=missing.json"], "no such file"),
        (["canvas=blue"], "canvas=blue is not a colour"),
        (["brush=oil"], "Available options in 'brush'"),
        (["size=abc"], "could not be converted to Integer"),
    ],
)
def test_bad_input_is_one_clear_line(args, words, painting, tmp_path):
    defaults = {"strokes": str(painting("tape")), "out": str(tmp_path / "o.png")}
    for arg in args:
        key, value = arg.split("=", 1)
        defaults[key] = value
    result = run(*[f"{k}={v}" for k, v in defaults.items()])
    assert result.returncode != 0
    assert words in result.stderr
    assert "Traceback" not in result.stderr
