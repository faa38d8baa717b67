"""Colour mode's per-stroke refinement: once shapes are fixed a painting is linear in its colours
(for every brush), and the refined colours come nearer the style's without leaving the bounds."""
import numpy as np
import pytest
import skimage.data
import torch

from nsp.brushes import BRUSHES
from nsp.colors import hex_color
from nsp.colors import parse_color
from nsp.colors import rgb_to_lab
from nsp.engine import paint_canvas
from nsp.experiments.style import ceiling
from nsp.style import Recoloring
from nsp.style.measures import coherence, color_distance, luminance_ssim
from nsp.style.refine import color_basis, colors, footprints, probes, refine_colors, style_spread, with_colors

HEIGHT, WIDTH = 20, 28


@pytest.mark.parametrize("name", list(BRUSHES))
def test_a_painting_is_its_colour_basis_times_its_colours(name):
    # 80 small strokes over a 60×72 canvas: most colours are probed several to a channel
    brush, height, width = BRUSHES[name], 60, 72
    generator = torch.Generator().manual_seed(0)
    strokes = brush.sample(80, generator)
    for kind in ("x", "y"):  # every control point near the first
        at = [i for i, k in enumerate(brush.kinds) if k == kind]
        strokes[:, at[1:]] = (strokes[:, at[:1]] + 0.1 * (strokes[:, at[1:]] - 0.5)).clamp(0, 1)
    strokes[:, [i for i, kind in enumerate(brush.kinds) if kind == "size"]] *= 0.25
    basis = color_basis(brush, strokes, height, width)
    table = torch.rand(len(colors(brush, strokes, torch.zeros(3))), 3, generator=generator)
    x, canvas = with_colors(brush, strokes, table)
    painted = paint_canvas(brush, x, height, width, canvas=canvas[:, None, None].expand(3, height, width))
    assert basis.shape == (height * width, len(table))
    assert torch.allclose((basis @ table).T.reshape(3, height, width), painted, atol=1e-5)
    assert painted.std() > 0.05  # the strokes show: the canvas is not one colour
    assert len(probes(footprints(brush, strokes, height, width), len(brush.color) // 3)) < len(table) / 3


@pytest.fixture(scope="module")
def painting():
    """40 watercolor strokes of random shapes in shades of one brown, their painting as the photo,
    and green-tinted grass as the style."""
    brush = BRUSHES["watercolor"]
    generator = torch.Generator().manual_seed(1)
    strokes = brush.sample(40, generator)
    shade = torch.rand(40, 1, generator=generator)
    strokes[:, list(brush.color)] = (torch.tensor([0.6, 0.4, 0.2]) * (0.4 + 0.6 * shade)).repeat(1, 2)
    photo = paint_canvas(brush, strokes, HEIGHT, WIDTH)
    grass = torch.from_numpy(np.asarray(skimage.data.grass()[:HEIGHT * 4:4, :WIDTH * 4:4], dtype=np.float32) / 255)
    return brush, strokes, photo, torch.stack([grass * 0.4, grass * 0.9, grass * 0.2])


def test_refined_colours_come_nearer_the_style_within_both_bounds(painting):
    # as colour mode takes the step: after the shared map (the style's mean and spread of hues)
    brush, strokes, photo, style = painting
    shared = Recoloring.fit(photo, style)
    start, canvas = shared.strokes(brush, strokes), shared(torch.ones(3))
    before = paint_canvas(brush, start, HEIGHT, WIDTH, canvas=canvas[:, None, None].expand(3, HEIGHT, WIDTH))
    floor = 0.9 * luminance_ssim(photo, photo)
    x, canvas = refine_colors(brush, start, canvas, photo, photo, style, floor, 0.045)
    refined = paint_canvas(brush, x, HEIGHT, WIDTH, canvas=canvas[:, None, None].expand(3, HEIGHT, WIDTH))
    assert color_distance(refined, style) < 0.7 * color_distance(before, style)
    assert luminance_ssim(refined, photo) >= floor
    assert coherence(photo, refined, seed=1) <= 0.045
    shape = [i for i in range(brush.d) if i not in brush.color]
    assert torch.equal(x[:, shape], strokes[:, shape])


def test_iterates_past_a_bound_are_taken_back_toward_the_start_not_dropped(painting):
    brush, strokes, photo, style = painting
    shared = Recoloring.fit(photo, style)
    start, canvas = shared.strokes(brush, strokes), shared(torch.ones(3))
    before = paint_canvas(brush, start, HEIGHT, WIDTH, tuple(canvas.tolist()))
    floor = 0.9 * luminance_ssim(photo, photo)
    # aimed past both bounds, the steps leave them by the first check: kept whole, no iterate would
    # be within both and the colours would come back as given; a share of each is
    x, canvas = refine_colors(brush, start, canvas, photo, photo, style, floor, 0.045, margin=-1.0)
    refined = paint_canvas(brush, x, HEIGHT, WIDTH, tuple(canvas.tolist()))
    assert color_distance(refined, style) < 0.7 * color_distance(before, style)
    assert luminance_ssim(refined, photo) >= floor and coherence(photo, refined, seed=1) <= 0.045


def test_the_bounds_hold_on_the_painting_as_its_files_write_it(painting):
    brush, strokes, photo, style = painting
    shared = Recoloring.fit(photo, style)
    start, canvas = shared.strokes(brush, strokes), shared(torch.ones(3))
    floor = 0.9 * luminance_ssim(photo, photo)
    # aimed past both bounds, the colours kept sit at a bound's edge, where the canvas colour's
    # rounding to #rrggbb could tip the painting past it
    x, canvas = refine_colors(brush, start, canvas, photo, photo, style, floor, 0.045, margin=-1.0)
    assert torch.equal(torch.tensor(parse_color(hex_color(canvas)), dtype=canvas.dtype), canvas)
    written = paint_canvas(brush, x, HEIGHT, WIDTH, hex_color(canvas))
    assert luminance_ssim(written, photo) >= floor and coherence(photo, written, seed=1) <= 0.045


def test_with_no_room_in_the_bounds_the_colours_come_back_as_given(painting):
    brush, strokes, photo, style = painting
    x, canvas = refine_colors(brush, strokes, torch.ones(3), photo, photo, style, floor=1.01, bound=0.045)
    assert torch.equal(x, strokes) and torch.equal(canvas, torch.ones(3))


def test_toward_a_grey_style_a_grey_painting_stays_grey(painting):
    brush, strokes, _, style = painting  # the case: no stroke takes a hue of its own
    grey = style.mean(0, keepdim=True).expand(3, -1, -1)
    spread = style_spread(grey)
    assert torch.allclose(spread / spread[0, 0], torch.diag(torch.tensor([1.0, 0, 0])), atol=2e-3)  # L* alone
    strokes = strokes.clone()
    shade = strokes[:, list(brush.color)].reshape(len(strokes), -1, 3).mean(-1)
    strokes[:, list(brush.color)] = shade.repeat_interleave(3, 1)
    photo = paint_canvas(brush, strokes, HEIGHT, WIDTH)
    floor = 0.9 * luminance_ssim(photo, photo)
    x, canvas = refine_colors(brush, strokes, torch.ones(3), photo, photo, grey, floor, 0.045)
    before, after = (rgb_to_lab(colors(brush, s, c)) for s, c in ((strokes, torch.ones(3)), (x, canvas)))
    assert (after[:, 0] - before[:, 0]).abs().max() > 0.01  # the lightness moved
    assert after[:, 1:].abs().max() < 5e-3  # a* and b* within 0.5 ΔE of grey: unseen


def test_the_ceiling_searches_past_colour_mode_within_the_targets(painting):
    brush, strokes, photo, style = painting  # photo: the plain painting itself, on white
    shared = Recoloring.fit(photo, style)
    floor = 0.9 * luminance_ssim(photo, photo)
    x, canvas = refine_colors(brush, shared.strokes(brush, strokes), shared(torch.ones(3)), photo, photo, style, floor,
                              0.045)
    styled = paint_canvas(brush, x, HEIGHT, WIDTH, tuple(canvas.tolist()))
    drop = 1 - color_distance(styled, style) / color_distance(photo, style)
    assert ceiling(brush, strokes, x, hex_color(canvas), photo, style, "white") >= drop - 0.01  # hex: 8-bit canvas
