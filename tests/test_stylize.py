"""Style transfer on strokes (paper §3.5): the style loss falls, colour mode keeps every shape, the
painting's colours move toward the style's, and the random backbone is deterministic."""
import subprocess
import sys

import numpy as np
import pytest
import skimage.data
import torch
from functools import partial

from nsp.brushes import get_brush
from nsp.engine import paint_canvas
from nsp.painter.losses import PaintLoss
from nsp.painter.schema import LossConfig
from nsp.painter.stylize import stylize
from nsp.style import StyleLoss, sliced_wasserstein

SIZE = 40


@pytest.fixture(scope="module")
def scene():
    """A small watercolor painting of an astronaut crop, and grass as the style."""
    brush = get_brush("watercolor")
    g = torch.Generator().manual_seed(0)
    target = torch.from_numpy(skimage.data.astronaut()[100:260:4, 150:310:4].copy()).permute(2, 0, 1).float() / 255
    strokes = brush.sample(24, g)
    strokes[:, 6:8] = 0.4 + 0.4 * strokes[:, 6:8]  # broad strokes that cover the canvas
    grass = torch.from_numpy(np.asarray(skimage.data.grass()[:160:4, :160:4], dtype=np.float32) / 255)
    style = torch.stack([grass * 0.4, grass * 0.9, grass * 0.2])[None]  # green texture
    return brush, strokes, target, style


def run(scene, mode, steps=25, seed=0, callbacks=()):
    brush, strokes, target, style_image = scene
    style = StyleLoss(style_image, "random", seed=seed, color_weight=2.0 if mode == "color" else 0.0)
    return stylize(brush, strokes, target, PaintLoss.from_config(LossConfig()), style, partial(torch.optim.RMSprop, lr=0.01),
                   weight=0.5, steps=steps, mode=mode, callbacks=callbacks), style


def test_the_style_loss_falls_during_the_style_steps(scene):
    seen = []
    run(scene, "full", callbacks=[lambda step, losses: seen.append(losses["style"])])
    assert len(seen) == 25 and seen[-1] < 0.8 * seen[0]


def test_color_mode_keeps_every_shape_parameter_bit_for_bit(scene):
    brush, strokes, *_ = scene
    styled, _ = run(scene, "color")
    shape = [i for i in range(brush.d) if i not in brush.color]
    assert torch.equal(styled[:, shape], strokes[:, shape])
    assert not torch.equal(styled[:, list(brush.color)], strokes[:, list(brush.color)])


def test_colors_move_toward_the_style(scene):
    brush, strokes, target, style_image = scene
    styled, _ = run(scene, "color", steps=40)
    g = torch.Generator().manual_seed(1)

    def distance(x):
        with torch.no_grad():
            canvas = paint_canvas(brush, x, SIZE, SIZE, "white")[None]
            return float(sliced_wasserstein(canvas, style_image, 256, g))

    assert distance(styled) < 0.6 * distance(strokes)


def test_random_backbone_gives_identical_results_for_the_same_seed(scene):
    a, _ = run(scene, "full", steps=5, seed=3)
    b, _ = run(scene, "full", steps=5, seed=3)
    c, _ = run(scene, "full", steps=5, seed=4)
    assert torch.equal(a, b) and not torch.equal(a, c)


def paint_cli(tmp_path, *args, env=None):
    return subprocess.run(
        [sys.executable, "-m", "nsp.paint", "image=astronaut", "strokes=6", "work_size=48", "render_size=64",
         "animation_size=32", "animation_frames=3", "progress=false", f"hydra.run.dir={tmp_path}", *args],
        capture_output=True, text=True, env=env,
    )


def test_paint_with_a_style_image_writes_style_png(tmp_path):
    import PIL.Image

    PIL.Image.fromarray(skimage.data.coffee()).save(tmp_path / "coffee.png")
    result = paint_cli(tmp_path / "run", f"style.image={tmp_path / 'coffee.png'}", "style.backbone=random",
                       "style.steps=3", "style.size=32", "style.mode=color")
    assert result.returncode == 0, result.stderr
    assert PIL.Image.open(tmp_path / "run" / "style.png").size == (32, 21)  # coffee is 600×400
    assert (tmp_path / "run" / "final.png").exists()


def test_missing_vgg_weights_is_one_clear_error(tmp_path):
    import os

    PIL = pytest.importorskip("PIL.Image")
    PIL.fromarray(skimage.data.coffee()).save(tmp_path / "coffee.png")
    env = dict(os.environ, TORCH_HOME=str(tmp_path / "empty"))
    result = paint_cli(tmp_path / "run", f"style.image={tmp_path / 'coffee.png'}", env=env)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "VGG-19 weights not found" in lines[0] and "style.backbone=random" in lines[0]
