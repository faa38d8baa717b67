"""The vector engine: batching, resolution independence, range, determinism, soft-mode gradients."""
import dataclasses
import functools
import os
import subprocess
import sys

import pytest
import torch
import torch.nn.functional as F

from nsp.brushes import BRUSHES
from nsp.brushes.base import Pixels
from nsp.brushes.texture import EMBEDDED
from nsp.engine import composite, paint_canvas, render
from nsp.engine.kernels import antialiased, soft

pytestmark = pytest.mark.numerics  # make test runs these under other CPU kernels too

NAMES = list(BRUSHES)


def moderate(brush, n, generator):
    """Random strokes with sizes up to a third of the range, so several fit on a canvas."""
    x = brush.sample(n, generator)
    sizes = [i for i, k in enumerate(brush.kinds) if k == "size"]
    x[:, sizes] *= 0.35
    return x


@pytest.mark.parametrize("name", NAMES)
def test_batch_of_n_equals_n_single_renders(name, generator):
    brush = BRUSHES[name]
    x = moderate(brush, 6, generator)
    fg, alpha = render(brush, x, 40, 56)
    for i in range(len(x)):
        f1, a1 = render(brush, x[i : i + 1], 40, 56)
        assert torch.allclose(fg[i], f1[0], atol=1e-6) and torch.allclose(alpha[i], a1[0], atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_64_and_512_px_agree_after_downsampling(name, generator):
    brush = BRUSHES[name]
    x = moderate(brush, 8, generator)
    small = paint_canvas(brush, x, 64, 64, "white")
    large = F.avg_pool2d(paint_canvas(brush, x, 512, 512, "white")[None], 8)[0]
    assert (small - large).abs().mean() < 0.02
    psnr = -10 * torch.log10(((small - large) ** 2).mean())
    assert psnr > 25


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("softness", [None, 1.0])
def test_outputs_stay_in_unit_range(name, softness, generator):
    fg, alpha = render(BRUSHES[name], BRUSHES[name].sample(32, generator), 48, softness=softness)
    assert fg.shape == (32, 3, 48, 48) and alpha.shape == (32, 1, 48, 48)
    assert fg.min() >= 0 and fg.max() <= 1 and alpha.min() >= 0 and alpha.max() <= 1


@pytest.mark.parametrize("name", NAMES)
def test_same_seed_same_pixels(name):
    brush = BRUSHES[name]
    a = render(brush, brush.sample(16, torch.Generator().manual_seed(7)), 32)
    b = render(brush, brush.sample(16, torch.Generator().manual_seed(7)), 32)
    c = render(brush, brush.sample(16, torch.Generator().manual_seed(8)), 32)
    assert torch.equal(a[0], b[0]) and torch.equal(a[1], b[1]) and not torch.equal(a[1], c[1])


@pytest.mark.parametrize("name", NAMES)
def test_coarse_to_fine_culling_keeps_every_touched_tile(name, generator):
    # At 512 px, 8-px tiles are culled through 128- and 32-px ones; 64-px tiles are culled in one step.
    brush = BRUSHES[name]
    x = moderate(brush, 12, generator)
    fine, coarse = render(brush, x, 512, 384, tile=8), render(brush, x, 512, 384, tile=64)
    assert torch.allclose(fine[0], coarse[0], atol=1e-6) and torch.allclose(fine[1], coarse[1], atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("softness", [None, 0.5])
def test_culling_drops_no_pixel_a_stroke_paints(name, softness, generator):
    # Every pixel shaded directly, no tiles culled, against the engine; thin, tapered and curled
    # strokes on a canvas whose tiles overhang its edges, where a loose bound would be caught.
    brush = BRUSHES[name]
    x = torch.cat([moderate(brush, 150, generator), brush.sample(50, generator)])
    height, width = 45, 70
    py, px = torch.meshgrid(torch.arange(height, dtype=x.dtype), torch.arange(width, dtype=x.dtype), indexing="ij")
    pix = Pixels(px.reshape(1, -1).expand(len(x), -1), py.reshape(1, -1).expand(len(x), -1), height, width)
    coverage = antialiased if softness is None else functools.partial(soft, softness=softness)
    _, dense = brush.paint(x, pix, coverage)
    _, alpha = render(brush, x, height, width, softness=softness)
    # antialiased edges end within a pixel; a sigmoid's tail beyond the soft margin is below 1e-3
    assert (alpha.flatten(1) - dense).abs().max() < (1e-6 if softness is None else 1e-3)


def test_render_into_a_reused_buffer_overwrites_it(generator):
    brush = BRUSHES["watercolor"]
    x = moderate(brush, 5, generator)
    for height, width in [(32, 48), (30, 45)]:  # whole tiles, and a canvas the tiles overhang
        expected = torch.cat(render(brush, x, height, width), 1)
        out = torch.full((5, 4, height, width), 0.5)
        fg, alpha = render(brush, x, height, width, out=out)
        assert torch.equal(out, expected)
        assert fg.data_ptr() == out.data_ptr() and torch.equal(alpha, expected[:, 3:])


@pytest.mark.parametrize("name", NAMES)
def test_compiled_engine_matches_eager(name, generator):
    brush = BRUSHES[name]
    x = brush.sample(48, generator)
    eager = torch.cat(render(brush, x, 64), 1)
    fused = torch.cat(render(brush, x, 64, compile=True), 1)
    assert (fused - eager).abs().max() < 0.1  # an edge pixel may move by float rounding in the solver
    assert ((fused - eager).abs() > 1e-4).float().mean() < 1e-4


@pytest.mark.parametrize("name", NAMES)
def test_compiled_soft_renders_of_any_size_match_eager_with_their_gradients(name, generator):
    from nsp.engine import fused

    brush = BRUSHES[name]
    x = moderate(brush, 40, generator)
    for size in (48, 37):  # one kernel serves both: the canvas's size is one of its inputs
        outputs, grads = [], []
        for compile in (False, True):
            strokes = x.clone().requires_grad_()
            fg, alpha = render(brush, strokes, size, softness=brush.softness, compile=compile)  # the painter's kernels
            ((fg * torch.linspace(0, 1, size)).sum() + alpha.sum()).backward()  # a loss that weighs where the colour falls
            outputs.append(torch.cat([fg, alpha], 1).detach())
            grads.append(strokes.grad)
        assert (outputs[0] - outputs[1]).abs().max() < 1e-3  # a compiled cubic rounds differently
        assert torch.allclose(grads[0], grads[1], rtol=1e-2, atol=1e-2 * float(grads[0].abs().max()))
        assert grads[0].abs().sum() > 0
    assert all(fused.package(stage, brush.plain(), dict(softness=brush.softness, tile=8), x.device).exists()
               for stage in (fused.shade_any_size, fused.shade_any_size_grad))


def test_the_compiled_soft_shading_is_chosen_only_where_it_pays(monkeypatch, tmp_path):
    from nsp.engine import fused

    brush = BRUSHES["watercolor"]
    monkeypatch.setattr(fused, "CACHE", tmp_path)  # a machine that never compiled
    assert not fused.soft_pays(brush, 0.25, 5000)  # seconds saved: not worth a first compile
    assert fused.soft_pays(brush, 0.25, 1_000_000)
    for stage in (fused.shade_any_size, fused.shade_any_size_grad):
        kernel = fused.package(stage, brush, dict(softness=0.25, tile=8), torch.device("cpu"))
        kernel.parent.mkdir(parents=True, exist_ok=True)
        kernel.touch()
        assert fused.soft_pays(brush, 0.25, 500) == (stage is fused.shade_any_size_grad)  # both on disk: loading them pays
    assert not fused.soft_pays(brush, 0.5, 500)  # another edge's kernels
    assert not fused.soft_pays(BRUSHES["markerpen"], 0.25, 500)  # another brush's
    textured = dataclasses.replace(BRUSHES["oilpaint"], texture_path=str(tmp_path / "t.png"))
    assert not fused.soft_pays(textured, 0.5, 10**9)  # its texture is sampled at the canvas's size: no kernel of every size


def test_empty_batch_and_far_away_strokes_render_empty():
    brush = BRUSHES["tape"]
    fg, alpha = render(brush, torch.zeros(0, brush.d), 16)
    assert fg.shape == (0, 3, 16, 16)
    _, alpha = render(brush, torch.tensor([[0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]]), 16)
    assert alpha.sum() <= 0.5  # a zero-size stroke in the corner covers (almost) nothing


@pytest.mark.parametrize("name", NAMES)
def test_soft_mode_gradients_match_finite_differences(name, generator):
    brush = BRUSHES[name]
    x = moderate(brush, 3, generator).double().clamp(0.15, 0.85)
    weights = torch.rand(3, 4, 24, 24, generator=generator, dtype=torch.float64)

    def loss(params):
        fg, alpha = render(brush, params, 24, softness=1.5)
        return (torch.cat([alpha * fg, alpha], 1) * weights).sum()  # what compositing sees

    x.requires_grad_(True)
    (grad,) = torch.autograd.grad(loss(x), x)
    assert torch.all(grad.abs().sum(0) > 0), "every parameter gets a gradient"
    eps = 1e-5
    for _ in range(6):
        direction = torch.randn(x.shape, generator=generator, dtype=torch.float64)
        numeric = (loss(x + eps * direction) - loss(x - eps * direction)) / (2 * eps)
        assert torch.allclose((grad * direction).sum(), numeric, rtol=2e-3, atol=1e-4)


def test_composite_equals_stroke_by_stroke_blending(generator):
    fg, alpha = torch.rand(5, 3, 8, 8, generator=generator), torch.rand(5, 1, 8, 8, generator=generator)
    canvas = torch.rand(3, 8, 8, generator=generator)
    h = canvas
    for s, a in zip(fg, alpha):
        h = a * s + (1 - a) * h
    assert torch.allclose(composite(fg, alpha, canvas), h, atol=1e-6)


def test_composite_gradients_match_finite_differences(generator):
    """Through opaque pixels (α = 1) too, and onto a background shared by the batch."""
    fg = torch.rand(2, 4, 3, 5, 5, generator=generator, dtype=torch.float64)
    alpha = torch.rand(2, 4, 1, 5, 5, generator=generator, dtype=torch.float64)
    alpha[alpha > 0.7] = 1.0
    canvas = torch.rand(3, 5, 5, generator=generator, dtype=torch.float64)
    inputs = tuple(t.requires_grad_() for t in (fg, alpha, canvas))
    assert torch.autograd.gradcheck(composite, inputs)


def test_paint_canvas_keeps_the_aspect_ratio_and_background(generator):
    brush = BRUSHES["tape"]
    x = torch.tensor([[0.25, 0.5, 0.1, 0.1, 0.0, 1.0, 0.0, 0.0]])
    image = paint_canvas(brush, x, 30, 90, "#00ff00")
    assert image.shape == (3, 30, 90)
    assert torch.equal(image[:, 0, 0], torch.tensor([0.0, 1.0, 0.0]))
    red = (image[0] == 1) & (image[1] == 0)
    ys, xs = red.nonzero(as_tuple=True)
    # Positions scale with each side: x = 0.25 -> pixel 22.25 of 90, y = 0.5 -> 14.5 of 30.
    assert abs(xs.float().mean() - 22.25) < 0.6 and abs(ys.float().mean() - 14.5) < 0.6


def test_closest_point_on_a_bezier_matches_dense_sampling(generator):
    from nsp.brushes.geometry import bezier_nearest

    pts = torch.rand(64, 3, 2, generator=generator) * 100
    pts[:8, 1] = (pts[:8, 0] + pts[:8, 2]) / 2  # straight strokes too
    px = torch.rand(64, 50, generator=generator) * 140 - 20
    py = torch.rand(64, 50, generator=generator) * 140 - 20
    t = bezier_nearest(pts[:, 0], pts[:, 1], pts[:, 2], px, py)

    def dist(t):
        b = (1 - t)[..., None] ** 2 * pts[:, None, 0] + 2 * ((1 - t) * t)[..., None] * pts[:, None, 1]
        b = b + (t * t)[..., None] * pts[:, None, 2]
        return torch.sqrt((b[..., 0] - px) ** 2 + (b[..., 1] - py) ** 2)

    best = torch.stack([dist(torch.full_like(px, s)) for s in torch.linspace(0, 1, 401)]).amin(0)
    assert torch.all(dist(t) <= best + 1e-2)


def test_compiled_path_is_chosen_only_where_it_pays(generator, monkeypatch, tmp_path):
    from nsp.engine import fused
    from nsp.engine.kernels import shade_any_size, shade_tiles

    brush = BRUSHES["watercolor"]
    few, many = moderate(brush, 10, generator), moderate(brush, 20000, generator)
    monkeypatch.setattr(fused, "CACHE", tmp_path)  # a machine that never compiled
    assert not fused.pays(brush, few, 128, 128)
    assert not fused.pays(brush, many, 128, 128)  # seconds of eager work: not worth a first compile
    assert fused.pays(brush, many, 4096, 4096)  # an hour eager: worth even a first compile
    kernel = fused.package(shade_any_size, brush, dict(tile=8, softness=None), many.device)
    kernel.parent.mkdir(parents=True)
    kernel.touch()
    assert fused.pays(brush, many, 128, 128) and fused.pays(brush, many, 128, 96)  # on disk, for every size: loading it pays
    assert not fused.pays(brush, many, 128, 128, softness=1.0)  # not this kernel
    assert not fused.pays(brush, many.requires_grad_(), 4096, 4096)  # gradients stay eager
    assert not fused.pays(BRUSHES["tape"], few, 128, 128)
    oil = BRUSHES["oilpaint"]  # a kernel for every canvas that draws the same bristle scales
    strokes = moderate(oil, 20000, generator)
    assert oil.sized(1024) is oil.sized(768) is not oil.sized(2048) and oil.sized(64) is oil.plain()
    kernel = fused.package(shade_any_size, oil.sized(1024), dict(tile=8, softness=None), strokes.device)
    kernel.touch()
    assert fused.pays(oil, strokes, 1024, 1024) and fused.pays(oil, strokes, 1024, 768)
    assert not fused.pays(oil, strokes[:1000], 2048, 2048) and fused.pays(oil, strokes[:1000], 1024, 1024)
    textured = dataclasses.replace(oil, texture_path=EMBEDDED + "…", _cache={})  # sampled to each canvas: a kernel per size
    assert textured.sized(64) is None
    sized = fused.package(shade_tiles, textured, dict(height=1024, width=1024, tile=8, softness=None), strokes.device)
    sized.touch()
    assert fused.pays(textured, strokes, 1024, 1024) and not fused.pays(textured, strokes, 1024, 768)


def test_a_kernel_is_compiled_once_into_the_cache_and_falls_back_where_it_cannot_serve(generator, monkeypatch, tmp_path):
    from nsp.engine import fused
    from nsp.engine.kernels import shade_tiles, tile_offsets

    brush, consts = BRUSHES["tape"], dict(height=16, width=24, tile=8, softness=None)
    monkeypatch.setattr(fused, "CACHE", tmp_path)
    x, t, key = brush.sample(5, generator), torch.arange(5) % 6, torch.arange(5)
    dx, dy = tile_offsets(8, x)
    eager = shade_tiles(brush, x, t, key, dx, dy, **consts)
    compiled = fused.fused(shade_tiles, brush, (x, t, key), (dx, dy), **consts)
    assert list(tmp_path.rglob("*.pt2")) == [fused.package(shade_tiles, brush, consts, x.device)]
    assert all(torch.allclose(a, b, atol=1e-5) for a, b in zip(compiled, eager))
    stamp = fused.package(shade_tiles, brush, consts, x.device).stat().st_mtime_ns
    more, t, key = brush.sample(300, generator), torch.arange(300) % 6, torch.arange(300)  # another batch size: the same kernel
    again = fused.fused(shade_tiles, brush, (more, t, key), (dx, dy), **consts)
    assert fused.package(shade_tiles, brush, consts, x.device).stat().st_mtime_ns == stamp
    assert torch.allclose(again[1], shade_tiles(brush, more, t, key, dx, dy, **consts)[1], atol=1e-5)
    grad = more.clone().requires_grad_()
    fg, _ = fused.fused(shade_tiles, brush, (grad, t, key), (dx, dy), **consts)  # no backward in a kernel: eager
    assert fg.requires_grad


@pytest.mark.parametrize("content", [b"", b"PK\x03\x04 truncated", bytes(range(256)) * 4], ids=["empty", "truncated", "random"])
def test_a_corrupt_kernel_in_the_cache_is_removed_and_the_render_goes_on_without_it(content, generator, monkeypatch,
                                                                                    tmp_path, caplog):
    from nsp.engine import fused
    from nsp.engine.kernels import shade_tiles, tile_offsets

    brush, consts = BRUSHES["tape"], dict(height=16, width=24, tile=8, softness=None)
    monkeypatch.setattr(fused, "CACHE", tmp_path)
    x, t, key = brush.sample(5, generator), torch.arange(5) % 6, torch.arange(5)
    dx, dy = tile_offsets(8, x)
    path = fused.package(shade_tiles, brush, consts, x.device)
    path.parent.mkdir(parents=True)
    path.write_bytes(content)
    out = fused.fused(shade_tiles, brush, (x, t, key), (dx, dy), **consts)
    assert all(torch.equal(a, b) for a, b in zip(out, shade_tiles(brush, x, t, key, dx, dy, **consts)))
    assert not path.exists() and "could not be loaded" in caplog.text


def test_an_unwritable_kernel_cache_renders_without_compiling(generator, monkeypatch, tmp_path, caplog):
    from nsp.engine import fused

    (tmp_path / "file").write_text("")
    monkeypatch.setattr(fused, "CACHE", tmp_path / "file" / "kernels")  # its parent is a file: nothing can be made
    x = moderate(BRUSHES["tape"], 10, generator)
    assert torch.equal(paint_canvas(BRUSHES["tape"], x, 16, 24, compile=True), paint_canvas(BRUSHES["tape"], x, 16, 24))
    assert "cannot write" in caplog.text


def test_paint_canvas_compiled_equals_eager(generator):
    brush = BRUSHES["oilpaint"]  # its bristles drawn at this canvas's size: hashed noise, lit relief
    x = moderate(brush, 40, generator)
    eager = paint_canvas(brush, x, 560, 480, compile=False)
    fused = paint_canvas(brush, x, 560, 480, compile=True)
    assert (fused - eager).abs().max() < 0.1 and ((fused - eager).abs() > 1e-4).float().mean() < 1e-3


@pytest.mark.parametrize("chunk", [7, 1024])  # frames across chunks, and chunks holding many frames
def test_a_canvas_painted_until_each_frame_shows_exactly_the_strokes_before_it(generator, chunk):
    from nsp.engine.canvas import TiledCanvas

    brush = BRUSHES["watercolor"]
    x = moderate(brush, 30, generator)
    ends = [1, 4, 5, 12, 30]
    canvas = TiledCanvas(torch.ones(3, 24, 40))
    shown = {end: canvas.image().clone() for end in canvas.paint_until(brush, x, ends, chunk=chunk)}
    assert list(shown) == ends
    for end in ends:
        assert torch.allclose(shown[end], paint_canvas(brush, x[:end], 24, 40, compile=False), atol=1e-6)  # both eager


def test_paint_canvas_leaves_the_given_canvas_alone(generator):
    brush = BRUSHES["tape"]
    canvas = torch.rand(3, 16, 16, generator=generator)
    before = canvas.clone()
    painted = paint_canvas(brush, moderate(brush, 20, generator), 16, 16, canvas=canvas)
    assert torch.equal(canvas, before) and not torch.equal(painted, before)


@pytest.mark.parametrize("given, expected", [({}, ["PASSIVE", "10000"]), ({"OMP_WAIT_POLICY": "ACTIVE"}, ["ACTIVE", "None"])])
def test_openmp_threads_spin_briefly_then_sleep_unless_the_user_chose_a_policy(given, expected):
    env = {key: value for key, value in os.environ.items() if key not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    shown = subprocess.run([sys.executable, "-c", "import os, nsp; print(os.environ['OMP_WAIT_POLICY'], "
                            "os.environ.get('GOMP_SPINCOUNT'))"], env=env | given, capture_output=True, text=True,
                           check=True).stdout.split()
    assert shown == expected


@pytest.mark.parametrize("given, expected", [({}, "AUTO,STRICT"), ({"MKL_CBWR": "COMPATIBLE"}, "COMPATIBLE")])
def test_matrix_products_sum_in_one_order_whatever_the_load_unless_the_user_chose(given, expected):
    env = {key: value for key, value in os.environ.items() if key != "MKL_CBWR"}
    shown = subprocess.run([sys.executable, "-c", "import os, nsp; print(os.environ['MKL_CBWR'])"], env=env | given,
                           capture_output=True, text=True, check=True).stdout.strip()
    assert shown == expected


@pytest.mark.parametrize("name", ["oilpaint", "tape"])
def test_stroke_images_composited_in_order_are_the_painting(name):
    """What an SVG of stroke images holds (paint_canvas's ``images``): each stroke alone on the
    pixels it covers, which, blended in order over the canvas, give the painting itself; a stroke
    off the canvas has an empty image."""
    brush = BRUSHES[name]
    x = brush.sample(60, torch.Generator().manual_seed(3))
    x[:, 2:4] *= 0.4
    x[-1, :2] = torch.tensor([0.0, 1.0])  # centred on a corner: its image is a quarter of it
    x[-2, 0], x[-2, 2:4] = 1.0, 0.001  # a sliver on the right edge
    images = []
    with torch.no_grad():
        painting = paint_canvas(brush, x, 70, 90, "white", images=images)
    canvas = torch.ones(70, 90, 3)
    assert len(images) == len(x)
    for left, top, image in images:
        h, w = image.shape[:2]
        assert 0 <= left and left + w <= 90 and 0 <= top and top + h <= 70 and image.min() >= 0 and image.max() <= 1
        region = canvas[top : top + h, left : left + w]
        region += image[..., 3:] * (image[..., :3] - region)
    torch.testing.assert_close(canvas.permute(2, 0, 1), painting, atol=1e-5, rtol=0)
    assert 0 < images[-1][2].shape[0] * images[-1][2].shape[1] < 0.5 * (x[-1, 2] * 90) ** 2


@pytest.mark.parametrize("name", ["oilpaint", "watercolor"])
def test_blocks_composited_from_tiles_are_the_dense_composite_with_its_gradients(name):
    """composite_blocks (the painter's soft renders, tiles only) equals render + composite, blocks of
    different stroke counts included, and so do its gradients in the strokes and the backgrounds."""
    from nsp.engine.raster import composite_blocks

    brush, size = BRUSHES[name], 40
    x = brush.sample(9, torch.Generator().manual_seed(5))
    x[:, [2, 3] if name == "oilpaint" else [6, 7]] *= 0.5
    block = torch.tensor([0, 0, 0, 0, 2, 2, 2, 3, 3])  # block 1 has none
    under = torch.rand(4, 3, size, size, generator=torch.Generator().manual_seed(6))
    weights = torch.rand(4, 3, size, size, generator=torch.Generator().manual_seed(7))
    depth, place = 4, torch.tensor([0, 1, 2, 3, 0, 1, 2, 0, 1])

    def dense(x, under):
        fg, alpha = render(brush, x, size, softness=0.5)
        stacked = fg.new_zeros(4, depth, 3, size, size).index_put((block, place), fg)
        return composite(stacked, alpha.new_zeros(4, depth, 1, size, size).index_put((block, place), alpha), under)

    grads = []
    for paint in (dense, lambda x, under: composite_blocks(brush, x, block, under, softness=0.5)):
        xs, bg = x.clone().requires_grad_(True), under.clone().requires_grad_(True)
        out = paint(xs, bg)
        (out * weights).sum().backward()
        grads.append((out.detach(), xs.grad, bg.grad))
    for want, got in zip(*grads):
        torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-4)
    assert grads[0][1].abs().sum() > 0 and torch.equal(grads[1][0][1], under[1])  # an empty block is its background


def test_soft_gradients_are_the_same_every_time_on_several_threads():
    """A stroke's gradient sums those of its (stroke, tile) pairs in one order, so a painting of
    thousands of strokes is the same twice (a gather's gradient with repeated indices, x[b], sums
    them in whatever order its threads take)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        brush = BRUSHES["tape"]
        x = brush.sample(3000, torch.Generator().manual_seed(8)).requires_grad_(True)
        weights = torch.rand(3000, 4, 96, 96, generator=torch.Generator().manual_seed(9))
        grads = []
        for _ in range(6):
            x.grad = None
            fg, alpha = render(brush, x, 96, softness=0.5)
            ((fg * weights[:, :3]).sum() + (alpha * weights[:, 3:]).sum()).backward()
            grads.append(x.grad.clone())
        assert all(torch.equal(grads[0], grad) for grad in grads[1:])
    finally:
        torch.set_num_threads(threads)


@pytest.mark.parametrize("name", ["oilpaint", "markerpen"])
def test_paint_gains_are_the_error_each_stroke_alone_takes_away(name):
    """paint_gains (the painter's choice among candidate strokes, tiles only) is Σ w·|canvas − goal|
    less the same after the stroke alone is painted, each over its own block, as render computes it."""
    from nsp.engine.raster import paint_gains

    brush, size, generator = BRUSHES[name], 40, torch.Generator().manual_seed(12)
    x = brush.sample(10, generator)
    block = torch.tensor([0, 0, 0, 1, 1, 1, 1, 2, 2, 2])
    canvas, goal = torch.rand(3, 3, size, size, generator=generator), torch.rand(3, 3, size, size, generator=generator)
    weights = torch.rand(3, 1, size, size, generator=generator)
    with torch.no_grad():
        fg, alpha = render(brush, x, size, softness=0.5)
        painted = torch.lerp(canvas[block], fg, alpha)
        want = (((canvas[block] - goal[block]).abs() - (painted - goal[block]).abs()) * weights[block]).sum((1, 2, 3))
        got = paint_gains(brush, x, block, canvas, goal, weights, softness=0.5)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-3)
    assert want.abs().max() > 1 and len(set(want.argsort().tolist())) == 10


def test_one_kernel_draws_oils_bristles_on_every_canvas_of_the_same_detail(generator):
    from nsp.engine import fused

    oil = BRUSHES["oilpaint"]
    x = moderate(oil, 12, generator)
    for height, width in ((300, 600), (200, 900)):  # the same bristle scales drawn (python -m nsp.engine compiles it)
        eager = torch.cat(render(oil, x, height, width), 1)
        compiled = torch.cat(render(oil, x, height, width, compile=True), 1)
        assert (compiled - eager).abs().max() < 1e-3 and eager[:, 3].sum() > 1000
    assert fused.package(fused.shade_any_size, oil.sized(1024), dict(softness=None, tile=8), x.device).exists()
    assert oil.sized(600).variant != oil.plain().variant
