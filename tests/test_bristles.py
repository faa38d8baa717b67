"""Oil paint's bristle model: detail at the output's own scale (more streaks on a larger stroke, finer
ones on a larger render, never magnified texels), a dry and broken tail, a rounded head, ridges lit
from one side, a pattern of each stroke's own that every size repeats, and a soft mode that sees
the mean of what a large render shows."""
import numpy as np
import pytest
import torch
import torch.nn.functional as F

from nsp.brushes import BRUSHES, get_brush
from nsp.engine import paint_canvas, render

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too

OIL = BRUSHES["oilpaint"]
GREY = (0.5, 0.5, 0.5)


def stroke(x=0.5, y=0.5, w=0.6, h=0.25, theta=0.0, head=GREY, tail=GREY):
    return torch.tensor([[x, y, w, h, theta, *head, *tail]], dtype=torch.float32)


def painted(x, size, brush=OIL, background="white"):
    return paint_canvas(brush, x, size, size, background, compile=False)


def luminance(image):
    return image.mean(0)


def fine_share(patch, period=8):
    """The share of a patch's (h, w) variance at periods of ``period`` px or less."""
    spectrum = torch.fft.fft2(patch - patch.mean()).abs() ** 2
    fy = torch.fft.fftfreq(patch.shape[0])[:, None]
    fx = torch.fft.fftfreq(patch.shape[1])[None, :]
    fine = (fx**2 + fy**2).sqrt() >= 1 / period
    return float(spectrum[fine].sum() / spectrum.sum())


def body(image, size):
    """The middle of the default stroke's first half (no dry tail, no edges): (h, w)."""
    return luminance(image)[round(0.45 * size):round(0.55 * size), round(0.25 * size):round(0.45 * size)]


def test_a_large_render_shows_finer_detail_not_magnified_texels():
    small, large = painted(stroke(), 1024), painted(stroke(), 4096)
    magnified = F.interpolate(small[None], scale_factor=4, mode="bilinear", align_corners=False)[0]
    assert fine_share(body(small, 1024)) > 0.2  # bristle streaks at the pixel scale of a 1024-px render
    assert fine_share(body(large, 4096)) > 0.1  # and of a 4096-px one: fibres too fine for 1024 appear
    assert fine_share(body(large, 4096)) > 4 * fine_share(body(magnified, 4096))


def streaks(image, size, h):
    """Crossings of the mean across the stroke's middle, averaged over 16 px along: (count)."""
    half = round(h * size / 2) - 3
    rows = slice(round(size / 2) - half, round(size / 2) + half)
    profile = luminance(image)[rows, round(0.3 * size):round(0.3 * size) + 16].mean(1)
    profile = profile - profile.mean()
    return int((profile[1:] * profile[:-1] < 0).sum())


def test_a_larger_stroke_carries_more_bristle_streaks():
    wide, narrow = painted(stroke(h=0.24), 1024), painted(stroke(h=0.06), 1024)
    ratio = streaks(wide, 1024, 0.24) / streaks(narrow, 1024, 0.06)
    assert 2.5 < ratio < 6  # four times the height, about four times the streaks


def test_each_stroke_has_a_pattern_of_its_own_drawn_alike_at_every_size():
    twice = torch.cat([stroke(x=0.3, w=0.3), stroke(x=0.7, w=0.3)])  # the same stroke, painted as #0 and #1
    image = painted(twice, 1024)
    left, right = (luminance(image)[460:560, x - 80:x + 20] for x in (round(0.3 * 1023), round(0.7 * 1023)))
    assert torch.equal(image, painted(twice, 1024))  # deterministic
    assert (left - right).abs().mean() > 0.01  # two strokes, two patterns

    def detail(image):  # the pattern's fine part, at 1024 px
        image = F.avg_pool2d(luminance(image)[None, None], image.shape[-1] // 1024)[0, 0]
        return image - F.avg_pool2d(image[None, None], 9, 1, 4, count_include_pad=False)[0, 0]

    same = torch.corrcoef(torch.stack([detail(image).flatten(), detail(painted(twice, 2048)).flatten()]))[0, 1]
    reseeded = painted(twice, 1024, get_brush("oilpaint", seed=7))
    other = torch.corrcoef(torch.stack([detail(image).flatten(), detail(reseeded).flatten()]))[0, 1]
    assert same > 0.5 and abs(other) < 0.2


@pytest.mark.parametrize("size", [1024, 4096])
def test_the_tail_runs_dry_into_separate_streaks_and_the_head_is_rounded(size):
    _, alpha = render(OIL, stroke(w=0.6, h=0.2), size)
    alpha, length, inset = alpha[0, 0], 0.6 * size, size // 256  # inset: clear of the edges' raggedness
    left, right = 0.2 * (size - 1), 0.8 * (size - 1)
    rows = slice(round(0.4 * (size - 1)) + 4 * inset, round(0.6 * (size - 1)) - 4 * inset)
    middle = alpha[rows, round(left + 0.2 * length):round(left + 0.5 * length)]
    tail = alpha[rows, round(right - 0.08 * length):round(right - 0.02 * length)]
    assert middle.mean() > 0.97  # a full load of paint
    assert tail.mean() < 0.6 and tail.std() > 0.3  # the tail has run dry, in streaks of paint and of none
    if size == 4096:  # fine enough to draw every streak: crisp, not a translucent film
        assert ((tail > 0.1) & (tail < 0.9)).float().mean() < 0.3
    assert alpha[round(0.4 * (size - 1)) + 2 * inset, round(left) + 2 * inset] == 0  # the head's corners are rounded off
    assert alpha[size // 2, round(left) + 8 * inset] > 0.99  # its middle is painted


@pytest.mark.parametrize("size", [1024, 4096])
def test_the_relief_is_lit_from_one_side(size):
    """Streaks across the light (θ = 0.75: from the upper right to the lower left on screen, the
    light coming from the upper left) show lit and shaded sides; streaks along it (θ = 0.25), none."""
    flat = get_brush("oilpaint", impasto=False)
    centre = slice(round(0.48 * size), round(0.52 * size))
    light = {}
    for theta in (0.25, 0.75):
        x = stroke(w=0.3, h=0.1, theta=theta)
        light[theta] = luminance(painted(x, size) - painted(x, size, flat))[centre, centre]  # what the light adds
    assert light[0.75].std() > 3 * light[0.25].std()
    assert light[0.75].max() > 0.05 and light[0.75].min() < -0.05  # lighter slopes and darker ones


@pytest.mark.parametrize("size", [1024, 4096])
def test_a_dab_is_a_raised_mark_and_a_wide_stroke_a_gentle_swell(size):
    """The paint's body swells to a stroke's middle: across a dab of a few tracks (a small brush's mark)
    its slopes are steep, the side toward the light (up, for θ = 0) lighter and the other darker, the
    dab's mean colour unchanged; across a wide stroke the same swell is too gentle to see."""
    flat = get_brush("oilpaint", impasto=False)
    for h, steep in ((0.005, True), (0.1, False)):
        x = stroke(w=4 * h, h=h)
        lit = luminance(painted(x, size) - painted(x, size, flat))  # what the light adds
        _, alpha = render(OIL, x, size)
        half = round(h * size / 2)
        columns = slice(round(0.5 * size - h * size), round(0.5 * size + h * size))
        upper, lower = (lit[rows, columns] for rows in (slice(size // 2 - half, size // 2 - half // 3),
                                                        slice(size // 2 + half // 3, size // 2 + half)))
        if steep:
            assert upper.mean() > 0.03 and lower.mean() < -0.03
            assert abs(float((lit * alpha[0, 0]).sum() / alpha[0, 0].sum())) < 0.01
        else:
            assert abs(float(upper.mean() - lower.mean())) < 0.02


def test_the_soft_mode_sees_the_mean_of_a_large_render():
    """What the painter optimizes (the soft mode at its working resolution) averages to what
    final.png shows: the same cover and colour, stroke by stroke."""
    x = torch.cat([stroke(w=0.7, h=0.3, theta=0.1, head=(0.9, 0.2, 0.1), tail=(0.1, 0.3, 0.8)),
                   stroke(w=0.4, h=0.15, theta=0.6, head=(0.1, 0.1, 0.1), tail=(0.9, 0.9, 0.9))])
    fg, alpha = render(OIL, x, 64, softness=0.5)
    big_fg, big_alpha = render(OIL, x, 1024)
    big_alpha, big_paint = (F.avg_pool2d(v, 16) for v in (big_alpha, big_fg * big_alpha))
    assert (alpha.mean((2, 3)) - big_alpha.mean((2, 3))).abs().max() < 0.02
    assert ((fg * alpha).mean((2, 3)) - big_paint.mean((2, 3))).abs().max() < 0.02


def test_gradients_reach_every_parameter_through_the_soft_mode():
    x = stroke(w=0.5, h=0.2, theta=0.1, head=(0.9, 0.2, 0.1), tail=(0.1, 0.3, 0.8)).requires_grad_()
    fg, alpha = render(OIL, x, 64, softness=0.5)
    target = torch.rand(3, 64, 64, generator=torch.Generator().manual_seed(0))
    (alpha * fg + (1 - alpha) - target).abs().mean().backward()
    assert (x.grad.abs() > 0).all()


def test_a_users_texture_gives_the_paint_and_lights_its_relief(tmp_path):
    from PIL import Image

    ramp = np.tile([80, 170, 255, 170], (32, 16)).T  # (64, 32): ridges along u, 4 texels apart across
    Image.fromarray(ramp.astype(np.uint8)).save(tmp_path / "ridges.png")
    lit = painted(stroke(), 256, get_brush("oilpaint", texture=str(tmp_path / "ridges.png")))
    flat = painted(stroke(), 256, get_brush("oilpaint", texture=str(tmp_path / "ridges.png"), impasto=False))
    inside = (slice(110, 146), slice(80, 170))
    assert lit[:, inside[0], inside[1]].max() > flat[:, inside[0], inside[1]].max() + 0.05  # lit slopes
    assert lit[:, inside[0], inside[1]].min() < flat[:, inside[0], inside[1]].min() - 0.02  # shaded ones
