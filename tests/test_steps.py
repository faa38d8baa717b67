"""A level's steps in one shape (schedule.static, :mod:`nsp.painter.steps`): the same losses and strokes
as the free steps, and nothing in a step that a CUDA graph could not replay."""
from functools import partial

import pytest
import torch

from nsp.brushes import BRUSHES
from nsp.painter.optimize import RMSprop, bias_corrected
from nsp.painter.painter import Callback
from nsp.painter.renderer import AnalyticRenderer
from nsp.painter.steps import capturable
from syncs import HostWaits
from test_painter import l1, painter, patches

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too


class Losses(Callback):
    """Each step's losses, read as floats after the painting."""

    def __init__(self):
        self.steps = []

    def on_step(self, painter, step, losses):
        self.steps.append({name: value.clone() for name, value in losses.items()})


@pytest.mark.parametrize(("name", "trainable", "split"), [("watercolor", None, "error"), ("oilpaint", None, "uniform"),
                                                           ("markerpen", (4, 5, 6), "error")])
def test_fixed_steps_take_the_free_steps(name, trainable, split):
    """Every block and stroke in every step, those not moving hidden or weighted 0, the losses scaled
    to the moving blocks: step for step the losses of the free steps, which move the first k strokes
    of the blocks still taking strokes alone (blocks of 1–3 strokes, so the shapes change)."""
    target, runs = patches(48, 64), {}
    for static in (False, True):
        losses = Losses()
        p = painter(name, AnalyticRenderer(BRUSHES[name], softness=0.5, block_size=32, static=True), polish=3,
                    static=static, split=split, face_share=0, callbacks=[losses], trainable=trainable)
        strokes = p.paint(target, 40)
        runs[static] = (strokes, losses.steps, l1(p, strokes, target))
    (free, free_steps, free_l1), (fixed, fixed_steps, fixed_l1) = runs.values()
    assert fixed.shape == free.shape == (40, BRUSHES[name].d) and len(fixed_steps) == len(free_steps) > 40
    for a, b in zip(free_steps[:40], fixed_steps[:40]):  # later, float rounding sets placements apart
        assert a.keys() == b.keys()
        for term in a:
            torch.testing.assert_close(b[term], a[term], rtol=1e-4, atol=1e-6)
    assert fixed_l1 == pytest.approx(free_l1, rel=0.05)


@pytest.mark.parametrize("name", sorted(BRUSHES))
def test_a_fixed_step_reads_nothing_back_and_copies_nothing_in(name):
    """What a CUDA graph could not capture: a read of the device, a tensor of host data. Between two
    steps (no stroke placed between them) there is none of either, for every brush on blocks of 64 px;
    and the painter copies nothing in synchronously anywhere (a level's bookkeeping goes asynchronously)."""
    waits, copies = HostWaits(), HostWaits(copies=True)
    between = []

    class Calls(Callback):
        last, placed = (0, 0), True

        def on_strokes(self, painter, added):
            self.placed = True

        def on_step(self, painter, step, losses):
            now = (waits.total, copies.total)
            if not self.placed:
                between.append((now[0] - self.last[0], now[1] - self.last[1]))
            self.last, self.placed = now, False

    p = painter(name, AnalyticRenderer(BRUSHES[name], softness=0.5, block_size=64, static=True), polish=2,
                static=True, callbacks=[Calls()], face_share=0, trainable=range(1, BRUSHES[name].d))
    with waits, copies:
        p.paint(patches(96, 96), 30)
    assert len(between) > 30 and set(between) == {(0, 0)}, (waits.where, copies.where.most_common())
    assert copies.total > 0  # a level's render copies (its chunks' bounds): the counter sees what it should
    assert not [where for where in copies.where if where.startswith("painter/")]  # nor placing a stroke, nor a level


def test_only_an_optimizer_whose_step_never_changes_is_captured():
    x = [torch.zeros(3, requires_grad=True)]
    assert capturable(RMSprop(x)) and not capturable(bias_corrected(RMSprop(x)))
    assert capturable(torch.optim.Adam(x, capturable=True)) and not capturable(torch.optim.Adam(x))


@pytest.mark.skipif(not torch.cuda.is_available(), reason="a CUDA graph needs a GPU")
def test_a_captured_level_paints_what_the_eager_one_paints(caplog):
    target, runs = patches(48, 64).cuda(), []
    for optimizer in (partial(RMSprop, lr=0.01), partial(torch.optim.RMSprop, lr=0.01)):  # captured, then eager
        p = painter("watercolor", AnalyticRenderer(BRUSHES["watercolor"], softness=0.5, block_size=32), polish=3,
                    face_share=0)
        p.optimizer = optimizer
        runs.append(l1(p, p.paint(target, 40).cpu(), target.cpu()))
    assert "could not be captured" not in caplog.text
    assert runs[0] == pytest.approx(runs[1], rel=0.05)
