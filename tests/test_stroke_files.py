"""nsp's JSON stroke files round-trip exactly; reference .npz files import with their geometry."""
import json
import re

import numpy as np
import pytest
import torch

from nsp.brushes import BRUSHES
from nsp.engine import paint_canvas, render
from nsp.io.export import write_svg
from nsp.io.strokes import StrokeFile, StrokeFileError, load_strokes, save_strokes


@pytest.mark.parametrize("name", list(BRUSHES))
def test_json_round_trip_is_exact(name, tmp_path, generator):
    painting = StrokeFile(BRUSHES[name], BRUSHES[name].sample(20, generator), 480, 640, "#102030")
    save_strokes(tmp_path / "p.json", painting)
    back = load_strokes(tmp_path / "p.json")
    assert back.brush is BRUSHES[name] and (back.height, back.width, back.background) == (480, 640, "#102030")
    assert torch.equal(back.strokes, painting.strokes)
    data = json.loads((tmp_path / "p.json").read_text())
    assert data["version"] == 1 and data["canvas"]["aspect"] == pytest.approx(4 / 3)
    assert list(data["strokes"][0]) == list(BRUSHES[name].params)  # each stroke's named parameters


def test_a_glaze_round_trips_and_a_file_without_one_blends_as_before_glazes(tmp_path, generator):
    import dataclasses

    from nsp.brushes import get_brush
    from nsp.errors import BadInput

    glazing = dataclasses.replace(BRUSHES["watercolor"], glaze=0.4)
    save_strokes(tmp_path / "p.json", StrokeFile(glazing, glazing.sample(5, generator)))
    data = json.loads((tmp_path / "p.json").read_text())
    assert data["glaze"] == 0.4 and load_strokes(tmp_path / "p.json").brush.glaze == 0.4
    del data["glaze"]  # painted before strokes glazed: every stroke covered what was under it
    (tmp_path / "p.json").write_text(json.dumps(data))
    assert load_strokes(tmp_path / "p.json").brush.glaze == 0.0
    (tmp_path / "p.json").write_text(json.dumps(data | {"glaze": 2}))
    with pytest.raises(StrokeFileError, match=r"brush.glaze=2: expected a number from 0 .* to 1 \(a glaze: overlaps multiply\)"):
        load_strokes(tmp_path / "p.json")
    with pytest.raises(BadInput, match="brush.glaze applies to watercolor and markerpen only, not 'oilpaint'"):
        get_brush("oilpaint", glaze=0.5)
    for name in ("watercolor", "markerpen"):  # every form of it blends as it does, whichever was asked for first
        own = BRUSHES[name].glaze
        assert BRUSHES[name].plain().glaze == BRUSHES[name].sized(4096).glaze == own
        glazing = get_brush(name, glaze=0.5)
        assert glazing.plain().glaze == glazing.sized(4096).glaze == 0.5 and BRUSHES[name].plain().glaze == own


def test_an_empty_painting_round_trips(tmp_path):
    save_strokes(tmp_path / "e.json", StrokeFile(BRUSHES["oilpaint"], torch.zeros(0, 11)))
    assert load_strokes(tmp_path / "e.json").strokes.shape == (0, 11)
    path = npz(tmp_path / "e.npz", np.zeros((0, 5)), np.zeros((0, 6)), np.zeros((0, 1)))
    assert load_strokes(path, brush="oilpaint").strokes.shape == (0, 11)


def test_size_keeps_the_aspect_ratio():
    assert StrokeFile(BRUSHES["tape"], torch.zeros(0, 8), 480, 640).size(1024) == (768, 1024)


def npz(path, ctt, color, alpha):
    np.savez(path, x_ctt=np.asarray(ctt)[None], x_color=np.asarray(color)[None], x_alpha=np.asarray(alpha)[None])
    return path


def test_reference_watercolor_control_point_is_relative_and_radii_in_pixels(tmp_path):
    # P0 = (0.2, 0.2), P2 = (0.8, 0.8); relative P1 = (1, 0) -> absolute (0.8, 0.2); radius 1 + 0.25·W/4.
    path = npz(tmp_path / "w.npz", [[0.2, 0.2, 1.0, 0.0, 0.8, 0.8, 0.25, 0.25]], [[1, 0, 0, 0, 0, 1]], [[0.5]])
    painting = load_strokes(path, brush="watercolor", size=128)
    x = painting.strokes[0]
    assert torch.allclose(x[:6], torch.tensor([0.2, 0.2, 0.8, 0.2, 0.8, 0.8]))
    assert torch.allclose(x[6:8] * 128 / 4, torch.tensor([1 + 0.25 * 32] * 2))
    assert torch.allclose(x[8:], torch.tensor([1.0, 0, 0, 0, 0, 1, 0.5]))
    _, alpha = render(BRUSHES["watercolor"], painting.strokes, 128)
    # The curve passes B(0.5) = (P0 + 2 P1 + P2)/4 = (0.65, 0.35), well off the straight diagonal.
    assert alpha[0, 0, round(0.35 * 127), round(0.65 * 127)] == 0.5
    assert alpha[0, 0, 64, 64] == 0


def test_reference_markerpen_drops_its_unused_second_radius(tmp_path):
    path = npz(tmp_path / "m.npz", [[0.1, 0.5, 0.5, 0.5, 0.9, 0.5, 0.1, 0.9]], [[0, 1, 0]], [[1.0]])
    x = load_strokes(path, brush="markerpen", size=64).strokes[0]
    assert x.shape == (11,) and x[6] * 64 / 4 == pytest.approx(1 + 0.1 * 16)
    assert torch.allclose(x[7:], torch.tensor([0.0, 1, 0, 1]))


def test_reference_rectangle_is_tape_with_half_extents_and_its_alpha(tmp_path):
    path = npz(tmp_path / "t.npz", [[0.5, 0.5, 0.5, 0.25, 0.0]], [[0.2, 0.4, 0.6]], [[0.3]])
    painting = load_strokes(path, brush="tape", size=128)
    assert painting.brush.params[-1] == "A" and painting.strokes[0, -1] == pytest.approx(0.3)
    fg, alpha = render(painting.brush, painting.strokes, 128)
    cols = (alpha[0, 0] > 0.15).sum(0).nonzero().flatten()
    rows = (alpha[0, 0] > 0.15).sum(1).nonzero().flatten()
    # Half extents 1 + w·W/4 = 17 px and 1 + h·W/4 = 9 px around pixel 63.5.
    assert cols.max() - cols.min() + 1 == pytest.approx(34, abs=1)
    assert rows.max() - rows.min() + 1 == pytest.approx(18, abs=1)
    # The reference blends its rectangles with their alpha: on white, 0.3·colour + 0.7·white.
    canvas = paint_canvas(painting.brush, painting.strokes, 128, 128, "white")
    assert torch.allclose(canvas[:, 64, 64], 0.3 * torch.tensor([0.2, 0.4, 0.6]) + 0.7, atol=1e-5)


def test_reference_rectangles_turn_counter_clockwise_on_screen(tmp_path):
    # θ = 0.25 in the reference's convention: the long side turned 45° counter-clockwise on screen
    # (y down), from the lower left to the upper right of its centre.
    path = npz(tmp_path / "t.npz", [[0.5, 0.5, 0.8, 0.1, 0.25]], [[0.0, 0.0, 0.0]], [[1.0]])
    painting = load_strokes(path, brush="tape", size=129)
    _, alpha = render(painting.brush, painting.strokes, 129)
    d = round(20 / 2**0.5)  # 20 px along a diagonal: inside the 27-px half length, outside the 4-px half width
    assert alpha[0, 0, 64 - d, 64 + d] == 1 and alpha[0, 0, 64 + d, 64 - d] == 1  # upper right, lower left
    assert alpha[0, 0, 64 + d, 64 + d] == 0 and alpha[0, 0, 64 - d, 64 - d] == 0  # not the other diagonal


def test_opaque_reference_rectangles_are_nsp_tape(tmp_path):
    path = npz(tmp_path / "t.npz", [[0.5, 0.5, 0.5, 0.25, 0.0]], [[0.2, 0.4, 0.6]], [[1.0]])
    assert load_strokes(path, brush="tape", size=128).brush is BRUSHES["tape"]


def test_translucent_tape_round_trips_through_json_png_and_svg(tmp_path):
    painting = load_strokes(npz(tmp_path / "t.npz", [[0.5, 0.5, 0.5, 0.25, 0.3]], [[1, 0, 0]], [[0.4]]), brush="tape")
    save_strokes(tmp_path / "t.json", painting)
    back = load_strokes(tmp_path / "t.json")
    assert back.brush is painting.brush and torch.equal(back.strokes, painting.strokes)
    write_svg(tmp_path / "t.svg", back.brush, back.strokes, 64, 64)
    assert 'opacity="0.4000"' in (tmp_path / "t.svg").read_text()


def test_reference_oil_sizes(tmp_path):
    path = npz(tmp_path / "o.npz", [[0.5, 0.5, 0.5, 0.2, 0.0]], [[1, 0, 0, 0, 0, 1]], [[1.0]])
    x = load_strokes(path, brush="oilpaint", size=100).strokes[0]
    assert x[2] == pytest.approx((1 + 0.5 * 100) / 100) and x[3] == pytest.approx((1 + 0.2 * 100) / 100)


CANVAS = '{"format": "nsp-strokes", "version": 1, "brush": "tape", "canvas": {%s}, "strokes": %s}'


@pytest.mark.parametrize(
    "content, match",
    [
        ("{not json", "not valid JSON"),
        ('{"format": "other"}', "not an nsp stroke file"),
        ('{"format": "nsp-strokes", "version": 9}', "version 9"),
        ('{"format": "nsp-strokes", "version": 1, "brush": "oil"}', "unknown brush 'oil'"),
        ('{"format": "nsp-strokes", "version": 1, "brush": "tape", "strokes": [{"x": 1}]}', "malformed"),
        ('"nsp-strokes"', "not an nsp stroke file"),
        (CANVAS % ('"width": 0, "height": 9, "background": "white"', "[]"), r'expected "canvas": \{"width": pixels'),
        (CANVAS % ('"width": 9, "height": 9, "background": "blue"', "[]"), "its background 'blue' is not a colour"),
        (CANVAS % (f'"width": 9, "height": {10**400}, "background": "white"', "[]"),
         r"its canvas \(width 9, height a 401-digit number\) is no painting's; expected sides from 1 to 1000000000 pixels"),
        (CANVAS % ('"width": 1000000001, "height": 9, "background": "white"', "[]"), r"its canvas \(width 1000000001, height 9\)"),
        (CANVAS % ('"width": 9, "height": 9, "background": "white"', "[[0.5]]"), '"strokes": a list of objects'),
        (CANVAS % ('"width": 9, "height": 9, "background": "white"', '[{"x": "0.5"}, {}]'),
         "2 of 2 strokes lack a number for one of x, y, w, h"),
        (CANVAS % ('"width": 9, "height": 9, "background": "white"', json.dumps([dict.fromkeys("xywh", 0) | {
            "theta": 0, "R": 0, "G": 0, "B": 10**400}])), "far outside"),
    ],
)
def test_malformed_files_name_the_problem(tmp_path, content, match):
    (tmp_path / "bad.json").write_text(content)
    with pytest.raises(StrokeFileError, match=match):
        load_strokes(tmp_path / "bad.json")


def test_out_of_range_parameters_are_refused(tmp_path, generator):
    painting = StrokeFile(BRUSHES["tape"], BRUSHES["tape"].sample(2, generator))
    painting.strokes[1, 3] = 1.25
    save_strokes(tmp_path / "p.json", painting)
    with pytest.raises(StrokeFileError, match=r"p.json: 1 of 2 strokes .* in \[0, 1\], got 1.25 \(h of stroke 1\)"):
        load_strokes(tmp_path / "p.json")
    painting.strokes[1, 3], painting.strokes[0, 0] = float("inf"), float("nan")
    save_strokes(tmp_path / "p.json", painting)
    with pytest.raises(StrokeFileError, match=r"2 of 2 strokes .* got nan \(x of stroke 0\)"):
        load_strokes(tmp_path / "p.json")


def test_npz_needs_a_brush_and_matching_arrays(tmp_path):
    path = npz(tmp_path / "t.npz", [[0.5, 0.5, 0.5, 0.25, 0.0]], [[0.2, 0.4, 0.6]], [[0.3]])
    with pytest.raises(StrokeFileError, match="brush="):
        load_strokes(path)
    with pytest.raises(StrokeFileError, match=r"do not fit brush=watercolor.*\[1, N, 8\]"):
        load_strokes(path, brush="watercolor")
    path = npz(tmp_path / "t.npz", [[0.5, 0.5, 0.5, 0.25, 0.0]], [[0.2, 0.4, 0.6]], [[0.3, 0.3]])
    with pytest.raises(StrokeFileError, match=r"x_alpha \(1, 2\) do not fit brush=tape.*\[1, N, 1\]"):
        load_strokes(path, brush="tape")


def test_npz_strokes_must_be_finite(tmp_path):
    path = npz(tmp_path / "t.npz", [[0.5, 0.5, 0.5, 0.25, 0.0]] * 3, [[0.2, 0.4, 0.6], [0, 0, 0], [np.inf, 0, 0]],
               [[0.3], [np.nan], [1.0]])
    with pytest.raises(StrokeFileError, match=r"t.npz: 2 of 3 strokes hold NaN or infinite values \(first: stroke 1\)"):
        load_strokes(path, brush="tape")


def test_a_stroke_file_carries_its_texture_and_names_no_file_to_read(tmp_path):
    from PIL import Image

    from nsp.brushes import get_brush
    from nsp.brushes.texture import load_texture

    Image.fromarray(np.tile(np.arange(0, 256, 8, dtype=np.uint8), (8, 1))).save(tmp_path / "secret.png")
    brush = get_brush("oilpaint", texture=str(tmp_path / "secret.png"))
    save_strokes(tmp_path / "p.json", StrokeFile(brush, brush.sample(3, torch.Generator().manual_seed(0))))
    text = (tmp_path / "p.json").read_text()
    assert "secret" not in text and str(tmp_path) not in text
    assert torch.equal(load_texture(load_strokes(tmp_path / "p.json").brush.texture_path), load_texture(tmp_path / "secret.png"))
    data = json.loads(text)
    data["texture"] = str(tmp_path / "secret.png")  # a file that names a local image is refused, unread
    (tmp_path / "named.json").write_text(json.dumps(data))
    with pytest.raises(StrokeFileError, match='its "texture" is not an embedded image .* names no file to read'):
        load_strokes(tmp_path / "named.json")


def test_a_texture_that_is_not_a_plain_image_file_is_refused_at_once(tmp_path, monkeypatch):
    import os

    from PIL import Image

    from nsp.brushes import get_brush
    from nsp.errors import BadInput

    os.mkfifo(tmp_path / "pipe.png")  # opening it would block forever
    with pytest.raises(BadInput, match="pipe.png: no such image file"):
        get_brush("oilpaint", texture=str(tmp_path / "pipe.png"))
    Image.new("L", (64, 64)).save(tmp_path / "big.png")
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 1000)  # as a header claiming 100000 × 100000 would be
    with pytest.raises(BadInput, match="big.png is not a readable image .*decompression bomb"):
        get_brush("oilpaint", texture=str(tmp_path / "big.png"))


@pytest.mark.parametrize("bad", [-5.0, 1e300, 1.5])
def test_reference_values_outside_the_unit_range_are_refused_by_name(tmp_path, bad):
    ctt = [[0.5, 0.5, 0.5, 0.25, 0.0], [0.5, 0.5, bad, 0.25, 0.0]]
    path = npz(tmp_path / "t.npz", ctt, [[0.2, 0.4, 0.6]] * 2, [[1.0]] * 2)
    with pytest.raises(StrokeFileError, match=r"1 of 2 strokes have a value outside \[0, 1\] in x_ctt, got "
                                              + re.escape(f"{bad:g} (stroke 1, column 2)")):
        load_strokes(path, brush="tape")
