"""The transportation loss (paper §3.4): separable Sinkhorn, and why the painter needs it."""
from __future__ import annotations

import pytest
import torch

from nsp.brushes import get_brush
from nsp.engine import render
from nsp.painter.transport import dense_sinkhorn, sinkhorn, transport_loss

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too

SIZE = 48
PAPER = (48, 0.01, 5)  # the transportation loss as the painter runs it: grid, ε, Sinkhorn iterations
SIDE = 12.5 / SIZE  # half side 6.25 px: edges cut pixels at a quarter, away from coverage kinks


def tape_canvas(x: int, background: float = 0.0, ink: float = 1.0) -> tuple[torch.Tensor, torch.Tensor]:
    """A square tape stroke centred on pixel (x, 24) of a plain canvas.

    Antialiased engine, centred on a pixel: the partial pixels on its left and right edges are
    mirror images, so a small move keeps its area exact to the bit and the paper's zero-gradient
    example holds exactly. Returns its parameters (1, 8), differentiable, and the canvas
    (1, 3, H, W) in [0, 1].
    """
    centre = [x / (SIZE - 1), 24 / (SIZE - 1)]
    params = torch.tensor([[*centre, SIDE, SIDE, 0.0, ink, ink, ink]], requires_grad=True)
    fg, alpha = render(get_brush("tape"), params, SIZE)
    return params, alpha * fg + (1 - alpha) * background


@pytest.mark.parametrize(
    ("batch", "height", "width", "eps"),
    [
        (3, 8, 8, 0.01),
        (2, 12, 7, 0.01),
        (2, 5, 16, 0.05),
        (2, 16, 16, 0.003),
        (2, 24, 24, 0.1),
        (1, 48, 48, 0.01),  # the paper's grid and ε
    ],
)
def test_separable_matches_dense_reference(batch, height, width, eps):
    torch.manual_seed(height * width)
    a, b = torch.rand(batch, height, width), torch.rand(batch, height, width) ** 4  # b: sparser
    fast, slow = sinkhorn(a, b, eps=eps, iters=5), dense_sinkhorn(a, b, eps=eps, iters=5)
    torch.testing.assert_close(fast, slow, rtol=1e-4, atol=0)


def test_separable_gradient_matches_dense_reference():
    torch.manual_seed(0)
    a = torch.rand(2, 10, 13, requires_grad=True)
    b = torch.rand(2, 10, 13)
    (fast,) = torch.autograd.grad(sinkhorn(a, b).sum(), a)
    (slow,) = torch.autograd.grad(dense_sinkhorn(a, b).sum(), a)
    torch.testing.assert_close(fast, slow, rtol=1e-3, atol=1e-6)


@pytest.mark.parametrize(("start", "goal"), [(12, 36), (36, 12)])
@pytest.mark.parametrize("background", [0.0, 1.0])
def test_non_overlapping_stroke_has_no_l1_gradient_but_is_pulled_to_its_target(start, goal, background):
    ink = 1.0 - background  # white tape on black, black tape on white
    _, target = tape_canvas(goal, background, ink)
    params, canvas = tape_canvas(start, background, ink)
    l1 = (canvas - target).abs().mean()
    ot = transport_loss(canvas, target, *PAPER, background=(background,) * 3)
    (l1_grad,) = torch.autograd.grad(l1, params, retain_graph=True)
    (ot_grad,) = torch.autograd.grad(ot, params)
    assert l1_grad[0, 0] == 0  # the pixel loss is flat: moving the stroke only moves its area
    toward = 1.0 if goal > start else -1.0
    assert -toward * ot_grad[0, 0] > 0.1  # descent moves x towards the target


def test_loss_is_entropic_blur_for_identical_images_and_grows_with_distance():
    _, target = tape_canvas(30)
    shifts = (0, 1, 2, 4, 8, 16, 24)  # pixels to the left
    losses = [transport_loss(tape_canvas(30 - shift)[1], target, *PAPER).item() for shift in shifts]
    assert losses[0] < 0.01  # identical: only the entropic blur remains, about ε at most
    assert all(near < far for near, far in zip(losses, losses[1:]))
    assert losses[-1] > 20 * losses[0]


def test_batch_equals_loop_and_any_input_size():
    torch.manual_seed(1)
    canvas, target = torch.rand(3, 3, 64, 80), torch.rand(3, 3, 64, 80)
    batched = transport_loss(canvas, target, *PAPER)
    looped = torch.stack([transport_loss(c[None], t[None], *PAPER) for c, t in zip(canvas, target)]).mean()
    torch.testing.assert_close(batched, looped)


@pytest.mark.parametrize("background", [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (0.2, 0.5, 0.9)])
def test_gradients_are_finite_even_for_empty_images(background):
    blank = torch.tensor(background)[None, :, None, None].expand(2, 3, 32, 32)
    torch.manual_seed(2)
    photo = torch.rand(2, 3, 32, 32)
    for canvas, target in [(blank, blank), (blank, photo), (photo, blank)]:
        canvas = canvas.clone().requires_grad_()
        loss = transport_loss(canvas, target, *PAPER, background=background)
        (grad,) = torch.autograd.grad(loss, canvas)
        assert torch.isfinite(loss) and loss >= 0
        assert torch.isfinite(grad).all()
