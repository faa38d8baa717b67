"""Machine files (nsp.io.machine): which strokes a machine must paint, the passes of its pen that cover a
stroke, G-code's refills, HPGL's pens, and bad plot settings in one line."""
import math
import re

import numpy as np
import pytest
import torch

from nsp.brushes import BRUSHES, get_brush
from nsp.config import PlotConfig
from nsp.errors import BadInput
from nsp.io.machine import passes, visible, write_machine

TAPE = BRUSHES["tape"]


def tape(x, y, w, h, color=(0.2, 0.2, 0.2)):
    return [x, y, w, h, 0.0, *color]


def test_a_stroke_later_paint_hides_entirely_is_left_out_and_one_it_hides_in_part_is_not():
    strokes = torch.tensor([tape(0.3, 0.5, 0.1, 0.1), tape(0.62, 0.5, 0.1, 0.1), tape(0.5, 0.5, 0.5, 0.3)])
    strokes[2, 0] = 0.4  # the large stroke covers the first wholly, the second in part
    assert visible(TAPE, strokes, 100, 100).tolist() == [False, True, True]
    glazed = get_brush("watercolor", glaze=0.5)  # a glaze lets half of what is under it through
    x = torch.zeros(2, glazed.d)
    x[:, [0, 2, 4]], x[:, [1, 3, 5]], x[:, 8:14], x[:, 14] = 0.5, 0.5, 0.3, 1.0
    x[:, 6:8] = torch.tensor([[0.1, 0.1], [0.3, 0.3]])
    assert visible(glazed, x, 100, 100).tolist() == [True, True]
    assert visible(get_brush("watercolor", glaze=0.0), x, 100, 100).tolist() == [False, True]


def test_a_wide_stroke_is_drawn_in_parallel_passes_that_cover_its_width():
    stroke = np.array(tape(0.5, 0.5, 0.4, 0.1))  # 40 × 10 px on a 100-px canvas
    lines = passes(TAPE, stroke, 100, 100, scale=1.0, pen=2.5)
    assert len(lines) == 4
    ys = sorted(float(line.imag.mean()) for line in lines)
    assert np.allclose(np.diff(ys), 2.5) and math.isclose(ys[-1] - ys[0] + 2.5, 10, rel_tol=1e-6)
    assert all(math.isclose(abs(line[-1] - line[0]), 40, rel_tol=1e-6) for line in lines)
    assert len(passes(TAPE, stroke, 100, 100, scale=1.0, pen=20)) == 1  # a pen wider than the stroke: one pass


def test_gcode_pauses_for_paint_at_each_layer_and_every_n_strokes_within_the_page(tmp_path):
    strokes = torch.tensor([tape(0.1 + 0.1 * i, 0.5, 0.05, 0.02, (1.0, 0.0, 0.0) if i < 7 else (0.0, 0.0, 1.0))
                            for i in range(9)])
    write_machine(tmp_path / "p.gcode", TAPE, strokes, ["#ff0000", "#0000ff"], 100, 100, PlotConfig(refill="3"))
    gcode = (tmp_path / "p.gcode").read_text()
    assert gcode.count("\nM0 ") == 3 + 1  # 7 red strokes: 3 loads; 2 blue: 1
    assert "; layer 1: 1 #ff0000\n" in gcode and "; layer 4: 2 #0000ff\n" in gcode
    xy = np.array([[float(v[1:]) for v in line.split()[1:3]] for line in gcode.splitlines() if line.startswith("G01 X")])
    assert xy.min() >= 10 - 1e-6 and xy[:, 0].max() <= 200 + 1e-6 and xy[:, 1].max() <= 287 + 1e-6  # a4 within 10 mm


@pytest.mark.parametrize("setting, says", [
    (dict(page="b99"), "plot.page=b99: expected a page format"),
    (dict(pen="thick"), "plot.pen=thick: expected a length with its unit"),
    (dict(refill="0"), "plot.refill=0: expected a number of strokes from 1, or a length (2m)"),
    (dict(margin="200mm"), "margins that leave some of the a4 page"),
])
def test_bad_plot_settings_are_one_line_naming_them(setting, says, tmp_path):
    strokes = torch.tensor([tape(0.5, 0.5, 0.2, 0.1)])
    with pytest.raises(BadInput, match=re.escape(says)) as error:
        write_machine(tmp_path / "p.gcode", TAPE, strokes, ["#333333"], 100, 100, PlotConfig(**setting))
    assert "\n" not in str(error.value) and not (tmp_path / "p.gcode").exists()


def test_refills_are_g_codes_not_hpgls(tmp_path):
    strokes = torch.tensor([tape(0.5, 0.5, 0.2, 0.1)])
    with pytest.raises(BadInput, match="plot.refill=5 applies to G-code"):
        write_machine(tmp_path / "p.hpgl", TAPE, strokes, ["#333333"], 100, 100, PlotConfig(refill="5"))


def test_a_watercolor_stroke_is_plotted_in_pieces_as_wide_as_its_discs_under_one_opacity(tmp_path):
    import xml.etree.ElementTree as ET

    from nsp.io.plot import write_plot

    brush = BRUSHES["watercolor"]
    x = torch.zeros(1, brush.d)
    x[0, :6] = torch.tensor([0.1, 0.5, 0.5, 0.5, 0.9, 0.5])
    x[0, 6:8] = torch.tensor([0.02, 0.18])  # r0, r2: a diameter of 1 % to 9 % of the width
    x[0, 8:14], x[0, 14] = 0.3, 0.6
    write_plot(tmp_path / "plot.svg", brush, x, ["#4d4d4d"], 100, 200)
    group = ET.parse(tmp_path / "plot.svg").getroot().find("{*}g").find("{*}g")
    widths = [float(path.get("stroke-width")) for path in group.findall("{*}path")]
    assert group.get("opacity") == "0.600" and all(path.get("stroke-opacity") is None for path in group)
    assert widths == sorted(widths) and len(widths) == 4
    assert math.isclose(widths[0], (0.02 + 0.16 / 8) * 200 / 2) and math.isclose(widths[-1], (0.02 + 0.16 * 7 / 8) * 200 / 2)
