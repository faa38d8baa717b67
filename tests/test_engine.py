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
from nsp.engine import composite, paint_canvas, render
from nsp.engine.fused import CACHE as MACHINE_CACHE  # ~/.cache/nsp/kernels, before a test points it elsewhere
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


@pytest.mark.parametrize("glaze", [0.0, 0.5, 1.0])
def test_composite_equals_stroke_by_stroke_blending(generator, glaze):
    """Paint covers what is under it (glaze 0); a glaze multiplies it (1): α·s·h + (1 − α)·h."""
    fg, alpha = torch.rand(5, 3, 8, 8, generator=generator), torch.rand(5, 1, 8, 8, generator=generator)
    canvas = torch.rand(3, 8, 8, generator=generator)
    h = canvas
    for s, a in zip(fg, alpha):
        h = a * s * ((1 - glaze) + glaze * h) + (1 - a) * h
    assert torch.allclose(composite(fg, alpha, canvas, glaze), h, atol=1e-6)


def test_a_glaze_darkens_where_strokes_overlap_and_is_its_colour_on_white():
    fg, alpha = torch.full((2, 3, 1, 2), 0.6), torch.tensor([[[[1.0, 1.0]]], [[[1.0, 0.0]]]])
    for glaze, overlap in ((0.0, 0.6), (0.5, 0.48), (1.0, 0.36)):
        h = composite(fg, alpha, torch.ones(3, 1, 2), glaze)
        torch.testing.assert_close(h[:, 0], torch.tensor([[overlap, 0.6]] * 3))


@pytest.mark.parametrize("glaze", [0.0, 0.6])
def test_composite_gradients_match_finite_differences(generator, glaze):
    """Through opaque pixels (α = 1) too, and onto a background shared by the batch."""
    fg = torch.rand(2, 4, 3, 5, 5, generator=generator, dtype=torch.float64)
    alpha = torch.rand(2, 4, 1, 5, 5, generator=generator, dtype=torch.float64)
    alpha[alpha > 0.7] = 1.0
    canvas = torch.rand(3, 5, 5, generator=generator, dtype=torch.float64)
    inputs = tuple(t.requires_grad_() for t in (fg, alpha, canvas))
    assert torch.autograd.gradcheck(lambda *x: composite(*x, glaze), inputs)


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


@pytest.fixture
def cache(monkeypatch, tmp_path):
    """An empty kernel cache, and a process that has loaded, found and said nothing of kernels yet."""
    from nsp.engine import fused

    for name in ("_LOADED", "_FAILED", "_ON_DISK"):
        monkeypatch.setattr(fused, name, {})
    monkeypatch.setattr(fused, "_TOLD", set())
    monkeypatch.setattr(fused, "CACHE", tmp_path / "kernels")
    return tmp_path / "kernels"


def kernel_on_this_machine(stage, brush, softness):
    """A kernel of every canvas size in this machine's own cache (``make setup`` compiled them; compiled
    here only where it has not), for the tests that need a compiled one without compiling it."""
    from nsp.engine import fused

    cpu, consts = torch.device("cpu"), dict(softness=softness, tile=8)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fused, "CACHE", MACHINE_CACHE)
        if not (path := fused.package(stage, brush, consts, cpu)).exists():
            x = brush.sample(8, torch.Generator().manual_seed(0)).requires_grad_(stage is fused.shade_any_size_grad)
            fg, alpha = render(brush, x, 32, softness=softness, compile=True)
            if x.requires_grad:
                (fg.sum() + alpha.sum()).backward()
    assert path.exists()
    return path


def test_auto_paints_eagerly_without_kernels_and_names_the_command_that_compiles_them_once(generator, cache, caplog):
    brush = BRUSHES["watercolor"]
    x = moderate(brush, 12, generator)
    eager = paint_canvas(brush, x, 40, 56, compile=False)
    assert torch.equal(paint_canvas(brush, x, 40, 56), eager)  # compile=None: auto
    assert torch.equal(paint_canvas(brush, x, 40, 56, compile=None), eager)
    strokes = x.clone().requires_grad_()
    render(brush, strokes, 32, softness=brush.softness, compile=None)[1].sum().backward()  # the painter's kind
    lines = [record.getMessage() for record in caplog.records]
    assert lines == ["compiled kernels: watercolor's are not on this machine; rendering eagerly "
                     "(`python -m nsp.engine watercolor` compiles them, once a machine)"]
    assert not cache.exists()  # nothing compiled


def test_the_command_named_is_the_one_that_compiles_the_missing_kernel():
    from nsp.engine import fused

    oil, cpu = BRUSHES["oilpaint"], torch.device("cpu")
    files = lambda width: fused.package(fused.shade_any_size, oil.sized(width), dict(softness=None, tile=8), cpu)
    soft = fused.package(fused.shade_any_size_grad, oil.plain(), dict(softness=oil.softness, tile=8), cpu)
    assert fused.engine_command("oilpaint", files(1024), 1024) == "python -m nsp.engine oilpaint"  # make setup's
    assert fused.engine_command("oilpaint", files(384), 384) == "python -m nsp.engine oilpaint"
    assert fused.engine_command("oilpaint", soft, 64) == "python -m nsp.engine oilpaint"
    assert fused.engine_command("oilpaint", files(2048), 2048) == "python -m nsp.engine oilpaint --width 2048"
    other = fused.package(fused.shade_any_size, oil.plain(), dict(softness=0.3, tile=8), cpu)
    assert fused.engine_command("oilpaint", other, 64) is None  # another softness: no command compiles it ahead


def test_auto_uses_the_kernels_on_disk(generator, monkeypatch):
    from nsp.engine import fused

    brush = BRUSHES["tape"]
    kernel_on_this_machine(fused.shade_any_size, brush, None)
    for name in ("_LOADED", "_FAILED", "_ON_DISK"):
        monkeypatch.setattr(fused, name, {})  # a fresh process
    x = moderate(brush, 30, generator)
    auto = paint_canvas(brush, x, 48, 64)
    assert [key[1] for key in fused._LOADED] == [fused.shade_any_size]
    assert (auto - paint_canvas(brush, x, 48, 64, compile=False)).abs().max() < 1e-4


def test_compile_false_never_touches_the_cache(generator, monkeypatch, cache):
    from nsp.engine import fused
    from nsp.painter.renderer import AnalyticRenderer

    def touched(*args, **kwargs):
        raise AssertionError("the kernel cache was looked at")

    monkeypatch.setattr(fused, "package", touched)
    monkeypatch.setattr(fused, "_ready", touched)
    brush = BRUSHES["oilpaint"]
    x = moderate(brush, 10, generator)
    paint_canvas(brush, x, 300, 400, compile=False)
    strokes = x.clone().requires_grad_()
    renderer = AnalyticRenderer(brush, compile=False)
    renderer.composite(strokes[None], None, torch.ones(1, 3, 32, 32)).sum().backward()
    assert not cache.exists()


@pytest.mark.parametrize(("other", "name"), [("markerpen", "oilpaint"), ("watercolor", "tape")],
                         ids=["same-width", "wider-strokes"])
def test_another_brushs_kernel_under_a_brushs_name_is_not_used(other, name, generator, cache, caplog, monkeypatch):
    import shutil

    from nsp.engine import fused

    loader = fused._Loader

    class Unrecorded:  # a package whose metadata names no path (compiled before it was recorded): the probe must tell
        load_metadata_from_package = staticmethod(lambda file, model: {})

        def __new__(cls, *args):
            return loader(*args)

    monkeypatch.setattr(fused, "_Loader", Unrecorded)
    brush, consts, cpu = BRUSHES[name].plain(), dict(softness=None, tile=8), torch.device("cpu")
    theirs = kernel_on_this_machine(fused.shade_any_size, BRUSHES[other].plain(), None)
    ours = fused.package(fused.shade_any_size, brush, consts, cpu)
    ours.parent.mkdir(parents=True)
    shutil.copyfile(theirs, ours)
    x = moderate(brush, 40, generator)
    assert torch.equal(paint_canvas(brush, x, 128, 96), paint_canvas(brush, x, 128, 96, compile=False))
    assert not ours.exists()
    assert [r.getMessage() for r in caplog.records] == [
        f"compiled kernels: {ours.name} does not draw what it is named for (a file of another brush or canvas?); "
        "removed it; rendering without it"]


def test_a_kernel_compiled_for_another_path_is_refused_before_it_runs(generator, monkeypatch, cache, caplog):
    from nsp.engine import fused

    brush, consts, cpu = BRUSHES["tape"], dict(softness=None, tile=8), torch.device("cpu")
    theirs, ours = (fused.package(fused.shade_any_size, brush, dict(consts, tile=tile), cpu) for tile in (8, 16))
    ours.parent.mkdir(parents=True)
    ours.write_bytes(b"a package")

    class Recorded:  # what compile_kernel records in a package; loading one to run it would fail this test
        load_metadata_from_package = staticmethod(lambda file, model: {fused.IDENTITY: fused._identity(theirs)})

    monkeypatch.setattr(fused, "_Loader", Recorded)
    x = moderate(brush, 30, generator)
    assert torch.equal(paint_canvas(brush, x, 64, 64, tile=16), paint_canvas(brush, x, 64, 64, tile=16, compile=False))
    assert not ours.exists() and f"{ours.name} was compiled for {fused._identity(theirs)}; removed it" in caplog.text


@pytest.mark.parametrize(("why", "free"), [("Failed to extract zip file x.so to destination file /tmp/x.so, mz_zip error "
                                            "string: write callback failed", 1 << 40), (None, 0)],
                         ids=["unpacking-fails", "no-room-to-unpack"])
def test_a_kernel_the_disk_cannot_unpack_is_kept_and_the_render_goes_eager(why, free, generator, monkeypatch, cache,
                                                                           caplog):
    import collections
    import shutil

    from nsp.engine import fused

    brush, consts = BRUSHES["tape"], dict(softness=None, tile=8)
    path = fused.package(fused.shade_any_size, brush, consts, torch.device("cpu"))
    path.parent.mkdir(parents=True)
    shutil.copyfile(kernel_on_this_machine(fused.shade_any_size, brush, None), path)

    class Failing:
        load_metadata_from_package = staticmethod(lambda file, model: {})

        def __init__(self, *args):
            raise RuntimeError(why)

    monkeypatch.setattr(fused, "_Loader", Failing)
    monkeypatch.setattr(fused.shutil, "disk_usage", lambda where: collections.namedtuple("Usage", "free")(free))
    x = moderate(brush, 30, generator)
    for _ in range(2):  # asked once, not at every render
        assert torch.equal(paint_canvas(brush, x, 64, 64), paint_canvas(brush, x, 64, 64, compile=False))
    assert path.exists() and len(caplog.records) == 1 and "no room in" in caplog.text


def test_compile_true_on_a_full_disk_goes_eager_without_compiling_again(generator, monkeypatch, cache, caplog):
    import collections

    from nsp.engine import fused

    monkeypatch.setattr(fused.shutil, "disk_usage", lambda where: collections.namedtuple("Usage", "free")(1 << 20))
    brush = BRUSHES["tape"]
    x = moderate(brush, 10, generator)
    for _ in range(2):
        assert torch.equal(paint_canvas(brush, x, 16, 24, compile=True), paint_canvas(brush, x, 16, 24, compile=False))
    assert [r.getMessage() for r in caplog.records] == [
        f"compiled kernels: cannot write {cache} (No space left on device); rendering without it"]


@pytest.fixture
def full_disk(tmpfs):
    """A 3-MB filesystem holding a kernel of tape's and full."""
    from nsp.engine import fused

    kernel = kernel_on_this_machine(fused.shade_any_size, BRUSHES["tape"], None)
    copy = tmpfs / "nsp" / "kernels" / kernel.relative_to(fused.CACHE)
    copy.parent.mkdir(parents=True)
    copy.write_bytes(kernel.read_bytes())
    (tmpfs / "tmp").mkdir()
    with open(tmpfs / "taken", "wb", buffering=0) as taken:  # every byte left; unbuffered: closing it writes nothing
        try:
            while True:
                taken.write(bytes(64 * 1024))
        except OSError:
            pass
    return tmpfs


def test_a_full_disk_under_the_cache_and_the_temporary_dir_never_aborts_a_render(full_disk):
    script = """if True:
        import torch
        from nsp.brushes import BRUSHES
        from nsp.engine import paint_canvas
        tape = BRUSHES["tape"]
        x = tape.sample(200, torch.Generator().manual_seed(0))
        eager = paint_canvas(tape, x, 96, 128, compile=False)
        assert torch.equal(paint_canvas(tape, x, 96, 128), eager)  # auto: on disk, with no room to unpack it
        assert torch.equal(paint_canvas(tape, x, 96, 128, softness=0.7, compile=True), paint_canvas(tape, x, 96, 128,
                           softness=0.7, compile=False))  # true: a compile with no room to write it
        print("painted")
    """
    env = dict(os.environ, XDG_CACHE_HOME=str(full_disk), TMPDIR=str(full_disk / "tmp"))
    result = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stdout == "painted\n", result.stderr[-3000:]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 2 and "no room in" in lines[0] and "No space left on device" in lines[1], lines
    assert list(full_disk.rglob("*.pt2"))  # the kernel kept: the disk was at fault, not the file


def test_a_loaded_kernel_leaves_nothing_in_the_temporary_dir(tmp_path):
    """The loader's unpacked library is removed once it is loaded: a command's process, ended by
    os._exit (its destructors never run), left four dirs of 1.6 MB a painting in /tmp."""
    script = """
import os, torch
from nsp.brushes import BRUSHES
from nsp.engine import fused, paint_canvas
brush = BRUSHES["tape"]
x = brush.sample(40, torch.Generator().manual_seed(0))
compiled, eager = paint_canvas(brush, x, 64, 64), paint_canvas(brush, x, 64, 64, compile=False)
assert fused._LOADED and (compiled - eager).abs().max() < 0.1
print("painted", flush=True)
os._exit(0)
"""
    result = subprocess.run([sys.executable, "-c", script], env=os.environ | {"TMPDIR": str(tmp_path)},
                            capture_output=True, text=True, timeout=300)
    assert result.stdout == "painted\n", result.stderr[-2000:]
    assert list(tmp_path.iterdir()) == []


def test_python_m_nsp_engine_names_the_brushes_it_knows_when_given_another(capsys):
    from nsp.engine.__main__ import main

    assert main(["oilpaint", "nosuchbrush"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == "error: no brush 'nosuchbrush'; expected one of: oilpaint, watercolor, markerpen, tape\n"


def test_a_kernel_is_compiled_once_into_the_cache_and_falls_back_where_it_cannot_serve(generator, monkeypatch, tmp_path):
    from nsp.engine import fused
    from nsp.engine.kernels import shade_tiles, tile_offsets

    brush, consts = BRUSHES["tape"], dict(height=16, width=24, tile=8, softness=None)
    monkeypatch.setattr(fused, "CACHE", tmp_path)
    x, t, key = brush.sample(5, generator), torch.arange(5) % 6, torch.arange(5)
    dx, dy = tile_offsets(8, x)
    eager = shade_tiles(brush, x, t, key, dx, dy, **consts)
    compiled = fused.fused(shade_tiles, brush, (x, t, key), (dx, dy), **consts)
    path = fused.package(shade_tiles, brush, consts, x.device)
    assert list(tmp_path.rglob("*.pt2")) == [path]
    assert fused._Loader.load_metadata_from_package(str(path), "model")[fused.IDENTITY] == fused._identity(path)
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
    out = fused.fused(shade_tiles, brush, (x, t, key), (dx, dy), build=False, **consts)  # True: compiled afresh
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


@pytest.mark.parametrize("name,glaze", [("oilpaint", 0.0), ("tape", 0.0), ("tape", 0.7)])
def test_stroke_images_composited_in_order_are_the_painting(name, glaze):
    """What an SVG of stroke images holds (paint_canvas's ``images``): each stroke alone on the
    pixels it covers (a glaze: the colour it laid there), which, blended in order over the canvas,
    give the painting itself; a stroke off the canvas has an empty image."""
    brush = dataclasses.replace(BRUSHES[name], glaze=glaze)
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


@pytest.mark.parametrize("name,glaze", [("oilpaint", 0.0), ("watercolor", 0.0), ("watercolor", 0.8)])
def test_blocks_composited_from_tiles_are_the_dense_composite_with_its_gradients(name, glaze):
    """composite_blocks (the painter's soft renders, tiles only) equals render + composite, blocks of
    different stroke counts included, and so do its gradients in the strokes and the backgrounds."""
    from nsp.engine.raster import composite_blocks

    brush, size = dataclasses.replace(BRUSHES[name], glaze=glaze), 40
    x = brush.sample(9, torch.Generator().manual_seed(5))
    x[:, [2, 3] if name == "oilpaint" else [6, 7]] *= 0.5
    block = torch.tensor([0, 0, 0, 0, 2, 2, 2, 3, 3])  # block 1 has none
    under = torch.rand(4, 3, size, size, generator=torch.Generator().manual_seed(6))
    weights = torch.rand(4, 3, size, size, generator=torch.Generator().manual_seed(7))
    depth, place = 4, torch.tensor([0, 1, 2, 3, 0, 1, 2, 0, 1])

    def dense(x, under):
        fg, alpha = render(brush, x, size, softness=0.5)
        stacked = fg.new_zeros(4, depth, 3, size, size).index_put((block, place), fg)
        return composite(stacked, alpha.new_zeros(4, depth, 1, size, size).index_put((block, place), alpha), under,
                         glaze)

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


@pytest.mark.parametrize("name,glaze", [("oilpaint", 0.0), ("markerpen", 0.0), ("markerpen", 1.0)])
def test_paint_gains_are_the_error_each_stroke_alone_takes_away(name, glaze):
    """paint_gains (the painter's choice among candidate strokes, tiles only) is Σ w·|canvas − goal|
    less the same after the stroke alone is painted, each over its own block, as render computes it."""
    from nsp.engine.raster import paint_gains

    brush, size, generator = dataclasses.replace(BRUSHES[name], glaze=glaze), 40, torch.Generator().manual_seed(12)
    x = brush.sample(10, generator)
    block = torch.tensor([0, 0, 0, 1, 1, 1, 1, 2, 2, 2])
    canvas, goal = torch.rand(3, 3, size, size, generator=generator), torch.rand(3, 3, size, size, generator=generator)
    weights = torch.rand(3, 1, size, size, generator=generator)
    with torch.no_grad():
        fg, alpha = render(brush, x, size, softness=0.5)
        painted = composite(fg[:, None], alpha[:, None], canvas[block], glaze)
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
