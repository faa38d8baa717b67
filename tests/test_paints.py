"""Painting with K paints: every stroke one of them, laid paint by paint (final.png in that order), and
plot.svg a layer a paint that a browser draws as final.png; bad paints refused in one line."""
import io
import json

import numpy as np
import pytest
import resvg_py as resvg
import torch
import vpype_cli
from PIL import Image

from nsp.brushes import get_brush
from nsp.colors import parse_color, rgb_to_lab
from nsp.engine import paint_canvas
from nsp.images import load_image, psnr, resize
from nsp.io.machine import visible
from nsp.io.strokes import load_strokes
from nsp.painter.paints import Paints, in_order, lay
from test_catalogue import run_cli

SMALL = ["work_size=64", "render_size=128", "animation_size=32", "progress=false"]


@pytest.mark.parametrize("override, says", [
    ("paints=40", "paints=40: expected a number of paints from 2 to 32"),
    ("paints=1", "paints=1: expected a number of paints from 2 to 32"),
    ("paints=[#c04020,#12345g]", "paints: #12345g is not a colour; expected #rrggbb"),
    ("paints=six", "paints=six: expected a number of paints"),
])
def test_bad_paints_are_one_line_naming_them(override, says, tmp_path, capsys, monkeypatch):
    code, err = run_cli("nsp.paint", [override, *SMALL, f"hydra.run.dir={tmp_path / 'run'}"], capsys, monkeypatch)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and says in lines[0], err


def test_paints_with_a_style_image_are_refused(tmp_path, capsys, monkeypatch):
    code, err = run_cli("nsp.paint", ["paints=4", "style.image=chelsea", *SMALL, f"hydra.run.dir={tmp_path / 'run'}"],
                        capsys, monkeypatch)
    assert code == 2 and "paints=4 with style.image=chelsea" in err and len(err.strip().splitlines()) == 1


def test_a_painting_in_three_paints_is_laid_layer_by_layer_and_plot_svg_draws_it(tmp_path, capsys, monkeypatch):
    out = tmp_path / "run"
    code, err = run_cli("nsp.paint", ["image=astronaut", "brush=markerpen", "strokes=40", "paints=3", "paint_steps=30",
                                      *SMALL, f"hydra.run.dir={out}"], capsys, monkeypatch)
    assert code == 0, err
    metrics = json.loads((out / "metrics.json").read_text())
    paints = metrics["paints"]
    assert metrics["laying_seconds"] > 0
    assert len(paints) == 3
    lightness = rgb_to_lab(torch.tensor([parse_color(p) for p in paints]))[:, 0]
    assert (lightness[:-1] >= lightness[1:]).all()  # light to dark, the default order
    strokes = load_strokes(out / "strokes.json").strokes
    brush = get_brush("markerpen")
    colors = (strokes[:, list(brush.color)] * 255).round().int().tolist()
    palette = [[round(c * 255) for c in parse_color(p)] for p in paints]
    layer = [palette.index(c) for c in colors]  # every stroke exactly one of the paints
    assert layer == sorted(layer)  # final.png and strokes.json in layer order
    svg = (out / "plot.svg").read_text()
    assert [f'inkscape:label="{i + 1} {p}"' in svg for i, p in enumerate(paints)] == [True] * 3
    assert svg.count("<path") == 40 and {line.split('stroke="')[1][:7] for line in svg.splitlines() if "<path" in line} <= set(paints)
    drawn = np.asarray(Image.open(io.BytesIO(bytes(resvg.svg_to_bytes(svg_path=str(out / "plot.svg"))))).convert("RGBA")) / 255
    on_paper = torch.tensor(drawn[..., :3] * drawn[..., 3:] + 1 - drawn[..., 3:]).permute(2, 0, 1).float()
    assert psnr(resize(on_paper, 128), resize(load_image(str(out / "final.png")), 128)) >= 26
    assert load_strokes(out / "strokes.json").paints == paints  # a machine's file can be made from it later
    assert len(vpype_cli.execute(f"read {out / 'plot.svg'}").layers) == 3  # vpype reads a layer a paint

    # The machines' files, as a user asks for them: G-code pausing for paint at each layer and every 10 strokes.
    code, err = run_cli("nsp.render", [f"strokes={out / 'strokes.json'}", f"out={tmp_path / 'plot.gcode'}",
                                       "plot.refill=10"], capsys, monkeypatch)
    assert code == 0, err
    shown = visible(brush, strokes, 128, 128)
    per_paint = [int(((torch.tensor(layer) == k) & torch.from_numpy(shown)).sum()) for k in range(3)]
    gcode = (tmp_path / "plot.gcode").read_text()
    assert gcode.count("\nM0 ") == sum(-(-n // 10) for n in per_paint) and gcode.rstrip().endswith("M2")
    code, err = run_cli("nsp.render", [f"strokes={out / 'strokes.json'}", f"out={tmp_path / 'plot.hpgl'}"],
                        capsys, monkeypatch)
    assert code == 0, err
    hpgl = (tmp_path / "plot.hpgl").read_text()
    assert hpgl.startswith("IN;") and [hpgl.index(f"SP{k};") for k in (1, 2, 3)] == sorted(hpgl.index(f"SP{k};") for k in (1, 2, 3))


def test_lay_keeps_a_users_paints_and_sorts_dark_first_when_told():
    brush = get_brush("tape")
    mine = torch.tensor([[0.9, 0.9, 0.8], [0.1, 0.1, 0.3]])
    paints = Paints(brush, in_order(mine, "dark_to_light"))
    assert torch.equal(paints.colors[0], mine[1])
    strokes = torch.rand(12, brush.d, generator=torch.Generator().manual_seed(0))
    laid, kept = lay(paints, strokes, torch.rand(3, 32, 48), "white", steps=3, tune=False)
    assert torch.allclose(kept.colors, (mine[[1, 0]] * 255).round() / 255)
    layer = paints.of(laid)
    assert layer.tolist() == sorted(layer.tolist()) and torch.equal(laid[:, list(brush.color)], kept.colors[layer])


def test_lay_moves_a_stroke_to_the_paint_the_painting_needs_not_the_nearest(monkeypatch):
    brush = get_brush("tape")
    paints = Paints(brush, torch.tensor([[0.85] * 3, [0.15] * 3]))  # light, then dark
    wide = torch.tensor([[0.5, 0.5, 1.0, 1.0, 0.0, 0.45, 0.45, 0.45]])  # over the whole canvas, nearest the dark paint
    light = torch.full((3, 32, 32), 0.85)
    assert paints.of(wide).tolist() == [1]
    laid, _ = lay(paints, wide, light, "white", steps=40, tune=False)
    assert paints.of(laid).tolist() == [0]  # the relaxed assignment found the light paint
    monkeypatch.setattr("nsp.painter.paints.CANDIDATES", 1)  # rounded to the nearest once, it could not
    laid, _ = lay(paints, wide, light, "white", steps=40, tune=False)
    assert paints.of(laid).tolist() == [1]


def test_lay_scores_a_wide_painting_on_its_own_canvas():
    brush = get_brush("tape")
    stroke = torch.tensor([[0.3, 0.3, 0.2, 0.1, 0.25, 0.1, 0.2, 0.6]])
    target = paint_canvas(brush, stroke, 32, 64)  # exactly this stroke, on a canvas twice as wide as high
    paints = Paints(brush, torch.tensor([[1.0, 1.0, 1.0], [0.1, 0.2, 0.6]]))
    laid, _ = lay(paints, stroke, target, "white", steps=30, tune=False)
    assert (laid[0, :5] - stroke[0, :5]).abs().max() < 0.02  # already right: it stays (scored on a padded square, it moved)


def test_opaque_media_paint_every_stroke_covering_and_refuse_a_glaze(tmp_path, capsys, monkeypatch):
    out = tmp_path / "run"
    code, err = run_cli("nsp.paint", ["image=astronaut", "brush=watercolor", "strokes=16", "paints=3", "paint_steps=10",
                                      "opaque=true", *SMALL, f"hydra.run.dir={out}"], capsys, monkeypatch)
    assert code == 0, err
    painting = load_strokes(out / "strokes.json")
    assert painting.brush.glaze == 0.0 and torch.equal(painting.strokes[:, painting.brush.alpha], torch.ones(16))
    code, err = run_cli("nsp.paint", ["opaque=true", "brush=watercolor", "brush.glaze=0.3", *SMALL,
                                      f"hydra.run.dir={tmp_path / 'no'}"], capsys, monkeypatch)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "opaque=true with brush.glaze=0.3: opaque paint covers what is under it" in err
