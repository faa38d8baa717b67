"""The painting step reads nothing back from the device (on a GPU each read stalls its queue): the
static renderer shapes every step by its strokes alone, and draws what the culling one draws."""
import pytest
import torch

from nsp.brushes import BRUSHES
from nsp.painter.renderer import AnalyticRenderer
from syncs import HostWaits
from test_painter import painter, patches

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too


@pytest.mark.parametrize("name", sorted(BRUSHES))
def test_static_renderer_draws_what_the_culling_one_draws(name):
    """Every stroke shaded on its whole block, the tiles it cannot reach masked: the same blocks,
    gradients and gains as shading only the tiles it touches, for blocks of 1–4 strokes."""
    brush, generator = BRUSHES[name], torch.Generator().manual_seed(3)
    x = brush.sample(12, generator).view(3, 4, -1)
    shown = torch.tensor([[1, 1, 1, 1], [1, 1, 0, 0], [1, 0, 0, 0]], dtype=torch.bool)
    under, goal = torch.rand(2, 3, 3, 40, 40, generator=generator)
    weights = torch.ones(3, 1, 40, 40)
    got = []
    for static in (False, True):
        renderer = AnalyticRenderer(brush, softness=0.5, compile=False, static=static)
        strokes = x.clone().requires_grad_()
        canvas = renderer.composite(strokes, shown, under)
        (canvas - goal).abs().sum().backward()
        gains = renderer.gains(x.flatten(0, 1), torch.arange(3).repeat_interleave(4), under, goal, weights)
        got.append((canvas.detach(), strokes.grad, gains))
    (culled, grad, gains), (whole, static_grad, static_gains) = got
    assert culled.sub(under).abs().amax() > 0.1  # the strokes paint
    torch.testing.assert_close(whole, culled, atol=1e-5, rtol=0)
    torch.testing.assert_close(static_grad, grad, atol=1e-3, rtol=1e-4)
    assert grad[1, 2:].abs().sum() == 0 and static_grad[1, 2:].abs().sum() == 0  # strokes not shown: no gradient
    torch.testing.assert_close(static_gains, gains, atol=1e-3, rtol=1e-4)


def test_painting_steps_read_nothing_back():
    """With the static renderer, an optimizer step reads nothing back from the device; what is read
    (a new stroke's placement, a level's bookkeeping and its render at its end) is a few reads a level."""
    between, levels = [], []

    class Reads:
        last, placed = 0, True

        def on_strokes(self, painter, added):
            self.placed = True

        def on_step(self, painter, step, losses):
            if not self.placed:
                between.append(waits.total - self.last)  # the reads of one whole step
            self.last, self.placed = waits.total, False

        def on_level(self, painter, level, canvas):
            levels.append(waits.total - sum(levels))

    renderer = AnalyticRenderer(BRUSHES["watercolor"], softness=0.5, block_size=32, static=True)
    painter("watercolor", renderer, face_share=0).paint(patches(48, 48), 40)  # the kernels' checks, once a process
    p = painter("watercolor", renderer, steps_per_stroke=4, polish=2, callbacks=[Reads()], face_share=0)
    with HostWaits() as waits:
        p.paint(patches(48, 48), 40)
    assert len(between) > 30 and set(between) == {0}
    assert len(levels) >= 2 and max(levels) <= 30, levels
