"""Watercolor and marker ink as their media look (nsp.brushes.pigment): the wash's dark rim and paper
grain, the marker's streaks and pools, each stroke's mean colour kept, and the plain form the painter
and the renderers' training data use."""
import pytest
import torch

from nsp.brushes import BRUSHES
from nsp.engine import paint_canvas, render

WASH = [0.2, 0.5, 0.5, 0.5, 0.8, 0.5, 0.3, 0.3, 0.30, 0.45, 0.70, 0.30, 0.45, 0.70, 0.9]  # radius 0.075 canvas widths
LINE = [0.2, 0.5, 0.5, 0.5, 0.8, 0.5, 0.1, 0.25, 0.45, 0.70, 0.8]  # a marker stroke, half width 0.025 canvas widths


def luminance(image: torch.Tensor) -> torch.Tensor:
    return (0.299 * image[0] + 0.587 * image[1] + 0.114 * image[2]).double()


def alone(name: str, stroke: list[float], size: int, plain: bool = False) -> torch.Tensor:
    brush = BRUSHES[name].plain() if plain else BRUSHES[name]
    with torch.no_grad():
        return paint_canvas(brush, torch.tensor([stroke]), size, size, "white", compile=False)


def fine_share(body: torch.Tensor) -> float:
    """The share of ``body``'s luminance variance at spatial periods of 8 px or less."""
    spectrum = torch.fft.fft2(body - body.mean()).abs() ** 2
    fy, fx = torch.fft.fftfreq(body.shape[0])[:, None], torch.fft.fftfreq(body.shape[1])[None, :]
    return float(spectrum[(fx**2 + fy**2).sqrt() >= 1 / 8].sum() / spectrum.sum())


@pytest.mark.parametrize("size", [1024, 2048])
def test_a_large_wash_darkens_at_its_rim_and_granulates_at_the_outputs_own_scale(size):
    lum = luminance(alone("watercolor", WASH, size))
    r, middle = 0.3 * size / 4, (size - 1) / 2
    across = (torch.arange(size, dtype=torch.float64) - middle).abs()
    cols = slice(round(0.3 * size), round(0.7 * size))
    darkness = 1 - lum[:, cols]
    rim = darkness[(across > 0.9 * r) & (across < 0.98 * r)].mean()
    centre = darkness[across < 0.3 * r].mean()
    assert rim / centre >= 1.15
    body = lum[round(middle - 0.8 * r):round(middle + 0.8 * r), cols]
    assert fine_share(body) >= 0.08  # the paper's grain at every size, finer in canvas terms as the render grows
    plain = luminance(alone("watercolor", WASH, size, plain=True))[round(middle - 0.8 * r):round(middle + 0.8 * r), cols]
    assert plain.std() < 1e-6  # the plain wash is flat: rim and grain are the look's


@pytest.mark.parametrize(("name", "stroke"), [("watercolor", WASH), ("markerpen", LINE)])
def test_the_look_keeps_each_strokes_mean_colour(name, stroke):
    looked, plain = alone(name, stroke, 1024), alone(name, stroke, 1024, plain=True)
    assert not torch.equal(looked, plain)
    inside = plain.mean(0) < 0.999  # the stroke's pixels on the white canvas
    for channel in range(3):
        change = looked[channel][inside].mean() - plain[channel][inside].mean()
        assert abs(float(change)) < 0.01


def test_the_paper_lies_on_the_canvas_under_every_stroke():
    """Two different washes (no rim: narrower than the rims start) over the same pixels show the same grain there."""
    brush = BRUSHES["watercolor"]
    first = [0.2, 0.5, 0.5, 0.5, 0.8, 0.5, 0.1, 0.1, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 1.0]
    second = [0.35, 0.48, 0.5, 0.5, 0.65, 0.51, 0.12, 0.08, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 1.0]
    with torch.no_grad():
        a, b = (paint_canvas(brush, torch.tensor([x]), 1024, 1024, "white", compile=False) for x in (first, second))
    patch = (slice(None), slice(505, 520), slice(480, 545))
    assert a[patch].std() > 0.01
    assert torch.allclose(a[patch], b[patch], atol=1e-5)


def test_marker_ink_streaks_along_the_stroke_and_pools_at_its_ends():
    lum = luminance(alone("markerpen", LINE, 2048))
    half, middle = 0.1 * 2048 / 4, 2047 / 2
    body = lum[round(middle - 0.7 * half):round(middle + 0.7 * half), round(0.35 * 2047):round(0.65 * 2047)]
    along = (body[:, 1:] - body[:, :-1]).pow(2).mean()  # neighbours along the stroke differ little
    across = (body[1:] - body[:-1]).pow(2).mean()  # neighbours across it, from streak to streak
    assert across > 5 * along
    rows = slice(round(middle - 0.5 * half), round(middle + 0.5 * half))
    ends = [lum[rows, round(x * 2047) - 20:round(x * 2047) + 20].mean() for x in (0.2, 0.8)]
    assert max(ends) < lum[rows, round(0.45 * 2047):round(0.55 * 2047)].mean()


@pytest.mark.parametrize("name", ["watercolor", "markerpen"])
def test_the_plain_form_has_no_detail_at_any_size(name):
    plain = BRUSHES[name].plain()
    assert not any(plain.varies(width) for width in (64, 1024, 4096))
    assert BRUSHES[name].varies(1024) and not BRUSHES[name].varies(64)



def test_a_plain_marker_stroke_is_one_colour():
    x = BRUSHES["markerpen"].sample(6, torch.Generator().manual_seed(0))
    x[:, BRUSHES["markerpen"].alpha] = 1.0
    fg, alpha = render(BRUSHES["markerpen"].plain(), x, 1024)
    covered = (alpha[:, 0] > 0.99)[:, None].expand_as(fg)
    colour = x[:, 7:10, None, None].expand_as(fg)
    assert covered.any() and torch.allclose(fg[covered], colour[covered], atol=1e-6)


def test_renderers_learn_the_plain_strokes():
    from nsp.training.data import StrokeData

    assert not StrokeData("watercolor", 64).brush.varies(4096)
