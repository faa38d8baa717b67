"""``python -m nsp.paint``: the files a painting leaves, what an interruption keeps, and bad input."""
import io
import json
import re
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf
from PIL import Image, ImageSequence

from nsp.brushes import BRUSHES
from nsp.errors import BadInput
from nsp.io.strokes import load_strokes
from nsp.painting.run import paint
from nsp.painting.schema import PaintConfig, paint_settings  # registers ``paint_schema`` and the ``brush`` group

CONF = Path(__file__).parents[1] / "conf" / "paint"
TINY = ["strokes=12", "work_size=48", "render_size=96", "animation_size=48", "animation_frames=4", "progress=false",
        "schedule.steps_per_stroke=3", "renderer.block_size=32"]


@pytest.fixture
def photo(tmp_path) -> Path:
    """A 60×40 landscape PNG: a red disc on a blue-green gradient."""
    y, x = np.mgrid[:40, :60]
    image = np.stack([x / 60, 0.5 + 0 * x, y / 40], -1)
    image[(x - 20) ** 2 + (y - 20) ** 2 < 100] = (0.9, 0.1, 0.1)
    path = tmp_path / "photo.png"
    Image.fromarray((image * 255).astype(np.uint8)).save(path)
    return path


def config(*overrides: str) -> PaintConfig:
    with initialize_config_dir(str(CONF), version_base="1.3"):
        return paint_settings(compose("paint", overrides=list(overrides)))


def test_a_painting_leaves_every_file_valid(photo, tmp_path):
    out = tmp_path / "run"
    metrics = paint(config(f"image={photo}", "brush=watercolor", f"output_dir={out}", *TINY, "schedule.detail_side=64"))

    assert Image.open(out / "final.png").size == (96, 64)  # long side render_size, the photo's 3:2 kept
    painting = load_strokes(out / "strokes.json")
    assert (painting.brush.name, len(painting.strokes), painting.width, painting.height) == ("watercolor", 12, 96, 64)
    assert ET.parse(out / "painting.svg").getroot().get("width") == "96"
    with Image.open(out / "animation.gif") as gif:
        assert gif.n_frames > 2 and gif.size == (48, 32)
    assert json.loads((out / "metrics.json").read_text()) == metrics
    assert set(metrics) == {"psnr", "ssim", "seconds", "painting_seconds", "strokes", "faces", "threads"}
    assert metrics["strokes"] == 12
    assert metrics["faces"] == 0
    assert 0 < metrics["painting_seconds"] < metrics["seconds"]
    assert metrics["psnr"] > 8  # the blank canvas scores 5 dB

    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    from tensorboard.backend.event_processing.plugin_event_multiplexer import EventMultiplexer

    assert set(EventMultiplexer().AddRunsFromDirectory(str(tmp_path)).Runs()) == {"run"}  # named after its run dir
    events = EventAccumulator(str(out)).Reload()
    assert set(events.Tags()["scalars"]) == {"loss/l1", "level/psnr", "final/psnr", "final/ssim"}  # total = l1 here
    assert set(events.Tags()["images"]) == {"canvas", "target"}
    levels = [e.step for e in events.Scalars("level/psnr")]
    assert [e.step for e in events.Images("canvas")] == levels and levels[-1] == events.Scalars("loss/l1")[-1].step
    target = events.Images("target")[0]
    assert {(e.width, e.height) for e in events.Images("canvas")} == {(target.width, target.height)}  # a finer level's too
    assert {Image.open(io.BytesIO(e.encoded_image_string)).size for e in events.Images("canvas")} == {(48, 32)}
    assert events.Scalars("final/psnr")[-1].value == pytest.approx(metrics["psnr"])
    from tensorboard.plugins.hparams.plugin_data_pb2 import HParamsPluginData

    run = HParamsPluginData.FromString(events.PluginTagToContent("hparams")["_hparams_/session_start_info"])
    assert run.session_start_info.hparams["brush"].string_value == "watercolor"
    assert run.session_start_info.hparams["strokes"].number_value == 12


def test_the_total_loss_is_logged_only_beside_two_terms_or_more():
    from nsp.painting.callbacks import TensorBoard

    class Writer:
        def __init__(self):
            self.scalars = []

        def add_scalar(self, tag, value, step):
            self.scalars.append(tag)

        @property
        def file_writer(self):  # where TensorBoard's callback adds its pictures
            return self

        def add_summary(self, summary, step):
            pass

        def flush(self):
            pass

    writer = Writer()
    board = TensorBoard(writer, torch.zeros(3, 4, 4))
    board.on_step(None, 1, {"l1": torch.tensor(0.5), "total": torch.tensor(0.5)})  # as the painter's, on its device
    board.on_step(None, 2, {"l1": torch.tensor(0.5), "ot": torch.tensor(0.1), "total": torch.tensor(0.51)})
    board.flush()
    assert writer.scalars == ["loss/l1", "loss/l1", "loss/ot", "loss/total"]


def test_animation_frames_add_the_same_strokes_each_or_one_a_stroke():
    from nsp.io.export import frame_ends

    assert frame_ends(500, 100) == list(range(0, 501, 5))
    assert frame_ends(12, 5) == [0, 3, 6, 9, 12]
    assert frame_ends(7, 3) == [0, 3, 6, 7]  # the last frame adds what is left
    assert frame_ends(4, None) == [0, 1, 2, 3, 4]
    assert frame_ends(0, 100) == [0]


def test_an_interrupted_painting_keeps_what_was_painted(photo, tmp_path, monkeypatch):
    from nsp.painting.callbacks import ProgressBar

    levels, stopped = [], []

    def ctrl_c(self, painter, step, losses):
        if levels and step == levels[0] + 2:  # two steps into the second level
            stopped.append(step)
            raise KeyboardInterrupt

    monkeypatch.setattr(ProgressBar, "on_level", lambda self, painter, level, canvas: levels.append(painter.step))
    monkeypatch.setattr(ProgressBar, "on_step", ctrl_c)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        paint(config(f"image={photo}", f"output_dir={out}", *TINY))
    assert 0 < len(load_strokes(out / "strokes.json").strokes) < 12
    assert Image.open(out / "final.png").size == (96, 64)
    assert not (out / "metrics.json").exists()
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    assert EventAccumulator(str(out)).Reload().Scalars("loss/l1")[-1].step == stopped[0]  # every loss up to the interruption


def test_a_painting_interrupted_while_its_files_are_written_keeps_its_strokes_and_picture(photo, tmp_path, monkeypatch):
    from nsp.painting import run

    info = run.log.info

    def sigterm(message, *args):  # SIGTERM arrives as KeyboardInterrupt (nsp.cli): here as "writing …" prints
        info(message, *args)
        if message.startswith("writing"):
            raise KeyboardInterrupt

    monkeypatch.setattr(run.log, "info", sigterm)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        paint(config(f"image={photo}", f"output_dir={out}", *TINY))
    assert len(load_strokes(out / "strokes.json").strokes) == 12  # the whole painting
    assert Image.open(out / "final.png").size == (96, 64)
    assert not (out / "metrics.json").exists()


def test_painting_seconds_count_the_work_after_the_last_stroke_is_placed(photo, tmp_path, monkeypatch):
    from nsp.painter.painter import Painter

    paint_strokes = Painter.paint

    def slow(self, *args, **kwargs):  # polish steps and the last canvas come after the bar's last stroke
        strokes = paint_strokes(self, *args, **kwargs)
        time.sleep(0.5)
        return strokes

    monkeypatch.setattr(Painter, "paint", slow)
    metrics = paint(config(f"image={photo}", f"output_dir={tmp_path / 'run'}", *TINY))
    assert metrics["painting_seconds"] >= 0.5


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("schedule.face_share=1.5", "schedule.face_share=1.5: expected a share of the strokes in [0, 1)"),
        ("style.image={strip}", "style.size=128: style.image is 1×128 px at that size, under the 4 px a side style "
                                "transfer needs; use style.size=1024 or more"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(override, message, photo, tmp_path):
    strip = tmp_path / "strip.png"  # too thin for style transfer at style.size
    Image.fromarray(np.zeros((2, 300, 3), dtype=np.uint8)).save(strip)
    out = tmp_path / "run"
    with pytest.raises(BadInput, match=re.escape(message)) as error:
        paint(config(f"image={photo}", override.format(strip=strip), f"output_dir={out}", *TINY[1:]))
    assert "\n" not in str(error.value)
    assert not out.exists()


def save_checkpoint(path: Path, brush: str) -> Path:
    """A tiny, untrained renderer saved as ``nsp.train`` saves one."""
    from nsp.training.module import RendererModule

    module = RendererModule({"_target_": "nsp.renderers.DualPathway", "size": 32, "channel_mult": 0.125}, brush,
                            optimizer=torch.optim.Adam)
    torch.save({"state_dict": module.state_dict(), "hyper_parameters": dict(module.hparams)}, path)
    return path


def test_the_neural_renderer_needs_a_checkpoint_of_the_same_brush(photo, tmp_path):
    checkpoint = save_checkpoint(tmp_path / "watercolor.ckpt", "watercolor")
    torch.save({"weights": torch.zeros(3)}, tmp_path / "other.ckpt")
    for path, brush, message in [
        (checkpoint, "oilpaint", "renders watercolor strokes, not brush=oilpaint"),
        (tmp_path / "other.ckpt", "watercolor", "is not an nsp renderer checkpoint"),
    ]:
        with pytest.raises(BadInput, match=message):
            paint(config(f"image={photo}", f"brush={brush}", "renderer=neural", f"renderer.checkpoint={path}",
                         f"output_dir={tmp_path / 'run'}", *TINY))
    metrics = paint(config(f"image={photo}", "brush=watercolor", "renderer=neural", f"renderer.checkpoint={checkpoint}",
                           f"output_dir={tmp_path / 'neural'}", *TINY))
    assert metrics["strokes"] == 12


def test_a_trained_renderer_paints_with_its_own_brush_unless_another_is_named(tmp_path):
    checkpoint = save_checkpoint(tmp_path / "watercolor.ckpt", "watercolor")
    small = ["strokes=4", "work_size=32", "render_size=48", "animation_size=32", "progress=false", "renderer=neural",
             f"renderer.checkpoint={checkpoint}"]
    result = run(*small, f"hydra.run.dir={tmp_path / 'own'}", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("painting astronaut with 4 strokes of the checkpoint's brush…")
    assert load_strokes(tmp_path / "own" / "strokes.json").brush.name == "watercolor"
    result = run(*small, "brush=oilpaint", f"hydra.run.dir={tmp_path / 'named'}", cwd=tmp_path)
    assert result.returncode == 2 and "renders watercolor strokes, not brush=oilpaint" in result.stderr


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nsp.paint", *args], capture_output=True, text=True, cwd=cwd)


def test_a_sweep_with_a_bad_value_among_its_own_is_one_line_and_leaves_no_dir(tmp_path):
    result = run("-m", "brush=tape,oil", f"hydra.sweep.dir={tmp_path / 'sweep'}", cwd=tmp_path)
    assert result.returncode != 0 and not (tmp_path / "sweep").exists()
    assert result.stderr.strip().splitlines() == [
        "error: brush=oil: no such brush; expected one of: markerpen, oilpaint, tape, watercolor"
    ]


def test_steps_of_one_shape_paint_as_the_free_steps_do_from_the_command_line(photo, tmp_path):
    """``schedule.static`` as a user types it: both settings paint every stroke, as well to rounding."""
    psnr = {}
    for static in ("true", "false"):
        out = tmp_path / static
        result = run(f"image={photo}", f"schedule.static={static}", "renderer.static=true", f"hydra.run.dir={out}",
                     *TINY, cwd=tmp_path)
        assert result.returncode == 0, result.stderr
        assert len(load_strokes(out / "strokes.json").strokes) == 12
        psnr[static] = json.loads((out / "metrics.json").read_text())["psnr"]
    assert psnr["true"] == pytest.approx(psnr["false"], abs=0.5)
    bad = run("schedule.static=maybe", f"hydra.run.dir={tmp_path / 'bad'}", cwd=tmp_path)
    assert bad.returncode == 2 and not (tmp_path / "bad").exists()
    assert bad.stderr.strip().splitlines() == [
        "error: Error merging override schedule.static=maybe: Value 'maybe' is not a valid bool (type str)"]


def test_a_multirun_paints_several_images_in_parallel_processes():
    with initialize_config_dir(str(CONF), version_base="1.3"):
        cfg = compose("paint", return_hydra_config=True)
    assert cfg.hydra.launcher._target_.endswith("JoblibLauncher") and cfg.hydra.launcher.n_jobs == -1


def test_a_painting_interrupted_before_its_first_stroke_leaves_a_stroke_file_that_renders(photo, tmp_path, monkeypatch):
    from nsp.painter.painter import Painter
    from nsp.render import RenderConfig, render

    def ctrl_c(self, target, n, detail=None, faces=()):
        raise KeyboardInterrupt

    monkeypatch.setattr(Painter, "paint", ctrl_c)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        paint(config(f"image={photo}", f"output_dir={out}", "background='#204060'", *TINY))
    assert len(load_strokes(out / "strokes.json").strokes) == 0
    again = render(OmegaConf.merge(OmegaConf.structured(RenderConfig),
                                   {"strokes": str(out / "strokes.json"), "out": str(tmp_path / "again.png"), "size": 30}))
    pixels = np.asarray(Image.open(again))
    assert pixels.shape == (20, 30, 3) and (pixels == (0x20, 0x40, 0x60)).all()


def test_a_painting_with_its_own_oil_texture_re_renders_identically_from_its_stroke_file(photo, tmp_path):
    from nsp.brushes.texture import load_texture
    from nsp.io.export import write_svg
    from nsp.render import RenderConfig, render

    def frames(path: Path) -> list[np.ndarray]:
        return [np.asarray(frame.convert("RGB")) for frame in ImageSequence.Iterator(Image.open(path))]

    texture = tmp_path / "bristles.png"
    Image.fromarray((np.random.default_rng(0).random((24, 96)) > 0.5).astype(np.uint8) * 255).save(texture)
    out = tmp_path / "run"
    tiny = [o for o in TINY if not o.startswith("animation_frames")]  # the animation as nsp.render draws one
    paint(config(f"image={photo}", f"output_dir={out}", f"brush.texture={texture}", *tiny))
    painting = load_strokes(out / "strokes.json")
    assert torch.equal(load_texture(painting.brush.texture_path), load_texture(texture))  # carried in the file
    assert str(tmp_path) not in (out / "strokes.json").read_text()  # it names no file
    for name, size in (("final.png", 96), ("painting.svg", 96), ("animation.gif", 48)):
        again = render(OmegaConf.merge(OmegaConf.structured(RenderConfig),
                                       {"strokes": str(out / "strokes.json"), "out": str(tmp_path / name), "size": size}))
        if name.endswith(".svg"):
            assert again.read_text() == (out / name).read_text()
        else:
            drawn, painted = frames(again), frames(out / name)
            assert len(drawn) == len(painted) and all((a == b).all() for a, b in zip(drawn, painted))
    write_svg(tmp_path / "own.svg", BRUSHES["oilpaint"], painting.strokes, 64, 96)  # nsp's own texture: another SVG
    assert (tmp_path / "own.svg").read_text() != (out / "painting.svg").read_text()


def test_a_glazed_painting_darkens_its_overlaps_and_re_renders_identically(photo, tmp_path):
    """``brush.glaze=``: the painter and every file blend the strokes so; the stroke file carries it."""
    from nsp.brushes import get_brush
    from nsp.engine import paint_canvas
    from nsp.render import RenderConfig, render

    out, tiny = tmp_path / "run", [o for o in TINY if not o.startswith("animation_frames")]
    paint(config(f"image={photo}", f"output_dir={out}", "brush=watercolor", "brush.glaze=0.8", *tiny))
    painting = load_strokes(out / "strokes.json")
    assert painting.brush.glaze == 0.8
    for name, size in (("final.png", 96), ("painting.svg", 96)):
        again = render(OmegaConf.merge(OmegaConf.structured(RenderConfig),
                                       {"strokes": str(out / "strokes.json"), "out": str(tmp_path / name), "size": size}))
        assert again.read_bytes() == (out / name).read_bytes()
    covering = paint_canvas(get_brush("watercolor", glaze=0.0), painting.strokes, 64, 96)  # the same strokes, covering
    glazed = torch.from_numpy(np.asarray(Image.open(out / "final.png"))).permute(2, 0, 1) / 255
    assert (glazed - covering).mean() < -0.01  # overlaps darker


def test_a_glaze_for_a_brush_that_has_none_is_one_line(tmp_path):
    result = run(*TINY[:4], "brush=oilpaint", "brush.glaze=0.5", f"hydra.run.dir={tmp_path / 'run'}", cwd=tmp_path)
    assert result.returncode != 0 and not (tmp_path / "run" / "final.png").exists()
    assert result.stderr.strip().splitlines() == ["error: brush.glaze applies to watercolor and markerpen only, not 'oilpaint'"]


def test_the_command_ends_at_once_with_its_files_and_its_log_complete(tmp_path):
    """``python -m nsp.paint`` ends with what it wrote all there, flushed, and its status the work's."""
    result = run(*TINY[:4], "progress=false", f"hydra.run.dir={tmp_path / 'run'}", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    last = result.stdout.strip().splitlines()[-1]
    assert last.startswith("painted 12 oilpaint strokes") and last.endswith(str(tmp_path / "run"))
    assert (tmp_path / "run" / "paint.log").read_text().strip().splitlines()[-1].endswith(last)
    assert json.loads((tmp_path / "run" / "metrics.json").read_text())["strokes"] == 12
    events = list((tmp_path / "run").glob("events.out.tfevents.*"))
    assert len(events) == 1 and events[0].stat().st_size > 1000
    refused = run(*TINY[:4], "progress=false", "strokes=-1", f"hydra.run.dir={tmp_path / 'bad'}", cwd=tmp_path)
    assert refused.returncode == 2 and refused.stderr.strip().splitlines() == ["error: strokes=-1: expected a positive number"]
