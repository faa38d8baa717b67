"""Each brush lights the pixels its parameters name, in the colours and alpha they name."""
import math

import pytest
import torch

from nsp.brushes import BRUSHES, get_brush
from nsp.engine import render

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too

S = 64


def grid(size=S):
    """Pixel coordinates (y, x), each (S, S)."""
    return torch.meshgrid(torch.arange(size, dtype=torch.float32), torch.arange(size, dtype=torch.float32), indexing="ij")


def one(brush, **values):
    spec = get_brush(brush)
    x = torch.tensor([[values[name] for name in spec.params]], dtype=torch.float32)
    fg, alpha = render(spec, x, S)
    return fg[0], alpha[0, 0]


def test_tape_lights_its_rotated_rectangle_only():
    # Centre (0.25, 0.75) of a 64-px canvas is pixel (15.75, 47.25); w = 0.5 -> 32 px, h = 0.25 -> 16 px.
    fg, alpha = one("tape", x=0.25, y=0.75, w=0.5, h=0.25, theta=0.25, R=0.2, G=0.4, B=0.6)
    yy, xx = grid()
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    along = (xx - 15.75) * c + (yy - 47.25) * s
    across = -(xx - 15.75) * s + (yy - 47.25) * c
    inside = (along.abs() <= 16 - 0.75) & (across.abs() <= 8 - 0.75)
    outside = (along.abs() >= 16 + 0.75) | (across.abs() >= 8 + 0.75)
    assert inside.sum() > 300
    assert torch.all(alpha[inside] == 1) and torch.all(alpha[outside] == 0)
    assert torch.allclose(fg[:, inside], torch.tensor([0.2, 0.4, 0.6])[:, None])
    assert torch.all(fg[:, outside] == 0)


def test_watercolor_is_a_swept_disc_with_interpolated_radius_colour_and_alpha():
    # Straight horizontal stroke at y = 0.5 from x = 0.2 to 0.8; radius 4 px at P0 and 12 px at P2.
    fg, alpha = one(
        "watercolor", x0=0.2, y0=0.5, x1=0.5, y1=0.5, x2=0.8, y2=0.5, r0=0.25, r2=0.75,
        R0=1.0, G0=0.0, B0=0.0, R2=0.0, G2=0.0, B2=1.0, A=0.6,
    )
    yy, xx = grid()
    cy, xa, xb = 0.5 * 63, 0.2 * 63, 0.8 * 63
    t = ((xx - xa) / (xb - xa)).clamp(0, 1)
    radius = 4 + 8 * t
    dist = torch.sqrt((xx - (xa + t * (xb - xa))) ** 2 + (yy - cy) ** 2)
    inside, outside = dist <= radius - 1.5, dist >= radius + 1.5
    assert torch.allclose(alpha[inside], torch.tensor(0.6))
    assert torch.all(alpha[outside] == 0)
    row = int(round(cy))
    assert fg[0, row, int(xa)] > 0.95 and fg[2, row, int(xa)] < 0.05  # C0 = red at P0
    assert fg[2, row, int(xb)] > 0.95 and fg[0, row, int(xb)] < 0.05  # C2 = blue at P2


def test_markerpen_has_square_tips_and_constant_thickness():
    fg, alpha = one("markerpen", x0=0.2, y0=0.5, x1=0.5, y1=0.5, x2=0.8, y2=0.5, d=0.5, R=0.0, G=1.0, B=0.0, A=1.0)
    cy, xa, xb, d = 31.5, 0.2 * 63, 0.8 * 63, 8.0
    # The flat tip covers the corners of the square cap, which a round tip would leave empty.
    assert alpha[round(cy - d + 2), round(xa - d + 2)] == 1
    assert alpha[round(cy + d - 2), round(xb + d - 2)] == 1
    yy, xx = grid()
    outside = ((yy - cy).abs() >= d + 1) | (xx <= xa - d - 1) | (xx >= xb + d + 1)
    assert torch.all(alpha[outside] == 0)
    assert torch.all(fg[1][alpha > 0] == 1)


def swept_disc_distance(x: torch.Tensor, radius: torch.Tensor, size: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Brute force in float64: min over 2001 t of |B(t) − p| − r(t), and its argmin t, each (S, S)."""
    pts = x[:6].double().view(3, 2) * (size - 1)
    t = torch.linspace(0, 1, 2001, dtype=torch.float64)[:, None]
    curve = (1 - t) ** 2 * pts[0] + 2 * (1 - t) * t * pts[1] + t**2 * pts[2]  # (T, 2)
    yy, xx = grid(size)
    sd = torch.cdist(curve, torch.stack([xx.flatten(), yy.flatten()], 1).double()) - radius.double()[:, None]
    best, at = sd.min(0)
    return best.view(size, size), t[at, 0].view(size, size)


@pytest.mark.parametrize("name", ["watercolor", "markerpen"])
def test_bezier_strokes_cover_their_swept_discs_without_holes(name, generator):
    """Random strokes over the whole parameter space (hooks, strong tapers, tiny radii) against brute force."""
    brush = BRUSHES[name]
    x = brush.sample(24, generator)
    x[:, brush.alpha] = 1
    _, alpha = render(brush, x, S)
    t = torch.linspace(0, 1, 2001)
    for stroke, a in zip(x, alpha[:, 0]):
        if name == "watercolor":
            sd, _ = swept_disc_distance(stroke, (stroke[6] + (stroke[7] - stroke[6]) * t) * S / 4, S)
            checked = torch.ones_like(sd, dtype=torch.bool)
        else:  # the round body between the square tips
            sd, at = swept_disc_distance(stroke, torch.full_like(t, float(stroke[6]) * S / 4), S)
            checked = (at > 0.01) & (at < 0.99)
        assert torch.all(a[checked & (sd < -0.75)] == 1), "a hole inside the stroke"
        assert torch.all(a[checked & (sd > 0.75)] == 0), "paint outside the stroke"


def test_bezier_control_point_bends_the_stroke():
    _, straight = one("markerpen", x0=0.1, y0=0.5, x1=0.5, y1=0.5, x2=0.9, y2=0.5, d=0.1, R=1, G=1, B=1, A=1)
    _, bent = one("markerpen", x0=0.1, y0=0.5, x1=0.5, y1=0.1, x2=0.9, y2=0.5, d=0.1, R=1, G=1, B=1, A=1)
    # B(0.5) = (P0 + 2 P1 + P2) / 4 -> y = 0.3 of the canvas: the bent stroke passes there, the straight one doesn't.
    assert bent[round(0.3 * 63), 32] == 1 and straight[round(0.3 * 63), 32] == 0
    assert straight[32, 32] == 1 and bent[32, 32] == 0


def test_oilpaint_is_opaque_textured_and_blends_head_to_tail():
    fg, alpha = one("oilpaint", x=0.5, y=0.5, w=0.8, h=0.3, theta=0.0, R0=1, G0=0, B0=0, R2=0, G2=0, B2=1)
    yy, xx = grid()
    outside = ((xx - 31.5).abs() >= 0.4 * 64 + 1) | ((yy - 31.5).abs() >= 0.15 * 64 + 1)
    assert torch.all(alpha[outside] == 0)
    assert alpha[32, 32] == 1  # opaque in the middle of the bristles
    head, tail = fg[:, 32, 16], fg[:, 32, 47]
    assert head[0] > 0.6 and head[2] < 0.3 and tail[2] > 0.6 and tail[0] < 0.3
    assert alpha[16:48, 8:56].std() > 0.05  # the texture is visible, not a flat rectangle


def test_oil_texture_can_be_a_users_image(tmp_path):
    from PIL import Image

    Image.new("L", (32, 8), 0).save(tmp_path / "empty.png")
    brush = get_brush("oilpaint", texture=str(tmp_path / "empty.png"))
    _, alpha = render(brush, torch.tensor([[0.5, 0.5, 0.8, 0.3, 0, 1, 0, 0, 0, 0, 1.0]]), S)
    assert alpha.max() == 0  # a black texture carries no paint


def test_unknown_brush_lists_the_valid_ones():
    with pytest.raises(ValueError, match="unknown brush 'oil'.*oilpaint, watercolor, markerpen, tape"):
        get_brush("oil")


def test_a_watercolor_stroke_curling_over_itself_shows_its_later_discs():
    """The reference draws a stroke's discs in order of t: where a hairpin's arms overlap, the later
    arm's colour shows, with no seam. Checked against discs painted one by one."""
    brush = BRUSHES["watercolor"]
    # P0 and P2 side by side, P1 far below: the arms run down and back up, overlapping between.
    x = torch.tensor([[0.40, 0.15, 0.5, 1.0, 0.60, 0.15, 0.45, 0.45, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0]])
    size = 64
    fg, alpha = render(brush, x, size)
    ys, xs = torch.meshgrid(torch.arange(size, dtype=torch.float32), torch.arange(size, dtype=torch.float32), indexing="ij")
    discs = torch.zeros(3, size, size)
    early, late = torch.zeros(size, size, dtype=torch.bool), torch.zeros(size, size, dtype=torch.bool)
    for t in torch.linspace(0, 1, 801):
        p = [(1 - t) ** 2 * x[0, i] + 2 * (1 - t) * t * x[0, i + 2] + t**2 * x[0, i + 4] for i in (0, 1)]
        r = (x[0, 6] + (x[0, 7] - x[0, 6]) * t) * size / 4
        covered = (xs - p[0] * (size - 1)) ** 2 + (ys - p[1] * (size - 1)) ** 2 <= r**2
        discs[:, covered] = (x[0, 8:11] + (x[0, 11:14] - x[0, 8:11]) * t)[:, None]
        early |= covered & (t < 0.3)
        late |= covered & (t > 0.7)
    overlap = early & late & (alpha[0, 0] > 0.99)
    assert overlap.sum() > 100
    # the later arm's colour throughout (colour by the nearest disc alone: 0.24 off; what remains is
    # the nearest disc's colour standing for the latest covering one's along each arm)
    assert (fg[0][:, overlap] - discs[:, overlap]).abs().mean() < 0.12
