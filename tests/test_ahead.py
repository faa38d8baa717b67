"""A painting's files made a level at a time (``PaintingFiles``), and in a process of their own while
it is painted (``nsp.painter.ahead``): the very files and scores of ``write_files``, the faces the painter
would find, and errors told."""
import errno
import json
import logging
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir

from nsp.brushes import get_brush
from nsp.cli import INTERRUPTED
from nsp.images import load_image, resize
from nsp.io.strokes import load_strokes
from nsp.paint import AHEAD_STROKES, _early, writes_ahead
from nsp.painter.ahead import FilesAhead
from nsp.painter.faces import find_faces
from nsp.painter.outputs import PaintingFiles, write_files

FILES = ("strokes.json", "final.png", "painting.svg", "animation.gif")
ASPECT, RENDER, ANIMATION, FRAMES = (40, 60), 96, 48, 6


def strokes_of(brush, count: int = 30):
    """Strokes as a painting makes them: broad ones first, then smaller ones."""
    x = torch.rand(count, brush.d, generator=torch.Generator().manual_seed(0))
    for i, kind in enumerate(brush.kinds):
        if kind == "size":
            x[:, i] *= torch.linspace(0.5, 0.1, count)
    return x


def made_at_once(out: Path, brush, strokes, photo) -> dict:
    out.mkdir()
    return write_files(out, strokes, brush, photo, "white", RENDER, ANIMATION, FRAMES, workers=2)


def same_files(a: Path, b: Path) -> None:
    for name in FILES:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize("name", ["oilpaint", "watercolor"])  # images in its SVG; vector elements
def test_files_made_a_level_at_a_time_are_those_made_at_once(name, tmp_path):
    brush, photo = get_brush(name), torch.rand(3, *ASPECT)
    strokes = strokes_of(brush)
    scores = made_at_once(tmp_path / "once", brush, strokes, photo)
    files = PaintingFiles(tmp_path / "levels", brush, photo, "white", RENDER, ANIMATION, FRAMES, len(strokes))
    (tmp_path / "levels").mkdir()
    for part in strokes[:22].split([2, 8, 12]):  # the last level's strokes come with finish
        files.add(part)
    assert files.finish(strokes) == scores
    same_files(tmp_path / "once", tmp_path / "levels")


def test_files_written_ahead_in_their_own_process_are_those_written_here(tmp_path):
    brush, photo = get_brush("oilpaint", seed=3), torch.rand(3, *ASPECT)
    strokes = strokes_of(brush)
    scores = made_at_once(tmp_path / "here", brush, strokes, photo)
    (tmp_path / "ahead").mkdir()
    ahead = FilesAhead()
    ahead.look_for_faces(None)
    try:
        ahead.begin(tmp_path / "ahead", dict(name="oilpaint", texture=None, seed=3, impasto=True), photo, "white", RENDER,
                    ANIMATION, FRAMES, len(strokes))
        for part in strokes.split([10, 20]):
            ahead.add(part)
        assert ahead.finish(strokes) == scores
    finally:
        ahead.close()
    assert ahead.process.returncode is not None  # ended
    same_files(tmp_path / "here", tmp_path / "ahead")


def test_a_files_process_that_fails_leaves_the_files_to_the_command_saying_why(tmp_path, caplog):
    ahead = FilesAhead()
    ahead.look_for_faces(None)
    try:
        ahead.begin(tmp_path, dict(name="crayon", texture=None, seed=0, impasto=True), torch.rand(3, *ASPECT), "white",
                    RENDER, ANIMATION, FRAMES, 3)
        with caplog.at_level(logging.WARNING, "nsp.painter.ahead"):
            assert ahead.finish(torch.rand(3, 13)) is None
    finally:
        ahead.close()
    assert "the process writing the files failed" in caplog.text and "crayon" in caplog.text
    assert "writing them here" in caplog.text
    assert not list(tmp_path.iterdir())


def test_a_file_the_process_cannot_write_is_the_commands_error(tmp_path):
    taken = tmp_path / "taken"
    taken.write_text("")  # a file where the run dir should be: no file can go into it
    ahead = FilesAhead()
    ahead.look_for_faces(None)
    try:
        ahead.begin(taken, dict(name="tape", texture=None, seed=0, impasto=True), torch.rand(3, *ASPECT), "white", RENDER,
                    ANIMATION, FRAMES, 3)
        with pytest.raises(OSError) as error:
            ahead.finish(torch.rand(3, get_brush("tape").d))
    finally:
        ahead.close()
    assert error.value.errno == errno.ENOTDIR and str(taken) in str(error.value.filename)


def test_a_painting_writes_ahead_on_its_own_with_every_core_and_enough_strokes(tmp_path):
    with initialize_config_dir(str(Path(__file__).parents[1] / "conf" / "paint"), version_base="1.3"):
        cfg = compose("paint")
        assert writes_ahead(cfg)  # this machine has 2 cores
        for override in (f"strokes={AHEAD_STROKES - 1}", "threads=2", "style.image=chelsea"):
            assert not writes_ahead(compose("paint", overrides=[override])), override


def test_a_single_painting_starts_its_files_process_before_its_config_is_read():
    for line in (["--help"], ["--cfg", "job"], ["-m", "seed=0,1"], ["seed=0,1", "hydra.mode=MULTIRUN"]):
        assert _early(line) is None, line  # no painting, or a sweep's: jobs a core each
    ahead = _early(["strokes=100", "image=chelsea"])
    try:
        assert isinstance(ahead, FilesAhead) and ahead.process.poll() is None
    finally:
        ahead.close()


def test_a_files_process_started_early_is_ended_where_the_config_writes_the_files_itself(tmp_path, capsys, monkeypatch):
    import nsp.paint
    from test_catalogue import run_cli

    made = []

    class Unused(FilesAhead):
        def __init__(self):
            super().__init__()
            made.append(self)

        def look_for_faces(self, *args):
            raise AssertionError("threads=1 paints on one core and writes its files itself")

    monkeypatch.setattr(nsp.paint, "FilesAhead", Unused)
    run = tmp_path / "run"
    code, err = run_cli("nsp.paint", [f"strokes={AHEAD_STROKES}", "threads=1", "work_size=32", f"render_size={RENDER}",
                                      f"animation_size={ANIMATION}", "progress=false", "schedule.steps_per_stroke=1",
                                      "schedule.polish=0", f"hydra.run.dir={run}"], capsys, monkeypatch)
    assert code == 0, err
    assert len(made) == 1 and made[0].process.returncode is not None  # started before the config was read; ended
    assert all((run / name).is_file() for name in FILES)


def test_a_painting_whose_files_were_written_ahead_has_those_files_and_scores(tmp_path):
    run = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "nsp.paint", f"strokes={AHEAD_STROKES}", "work_size=32", f"render_size={RENDER}",
                           f"animation_size={ANIMATION}", f"animation_frames={FRAMES}", "progress=false",
                           "schedule.steps_per_stroke=1", "schedule.polish=0", f"hydra.run.dir={run}"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["threads"] == 1  # the painter on one core, the files on the other
    painted = load_strokes(run / "strokes.json")
    photo = load_image("astronaut", max_side=256)
    scores = made_at_once(tmp_path / "here", painted.brush, painted.strokes, photo)
    assert {key: metrics[key] for key in scores} == scores
    same_files(run, tmp_path / "here")


def test_the_process_finds_the_faces_the_painter_would_find_in_its_target():
    ahead = FilesAhead()
    ahead.look_for_faces("astronaut", 1024, 256)
    try:
        found = ahead.faces()
        assert ahead.faces() is None  # one answer
    finally:
        ahead.close()
    assert found == find_faces(resize(load_image("astronaut", max_side=1024), 256)) and len(found) == 1


def test_faces_the_process_cannot_find_are_left_to_the_command(tmp_path):
    ahead = FilesAhead()
    ahead.look_for_faces(str(tmp_path / "nope.png"), 1024, 256)
    try:
        assert ahead.faces() is None  # the command searches, or tells what is wrong with the image
        ahead.begin(tmp_path, dict(name="tape", texture=None, seed=0, impasto=True), torch.rand(3, *ASPECT), "white",
                    RENDER, ANIMATION, FRAMES, 3)
        assert set(ahead.finish(torch.rand(3, get_brush("tape").d))) == {"psnr", "ssim"}  # and it goes on
    finally:
        ahead.close()


def test_the_process_says_when_it_is_at_work_and_when_it_is_done(tmp_path):
    ahead = FilesAhead()
    ahead.look_for_faces(None)
    try:
        assert ahead.working()  # starting: its imports
        waited = time.monotonic()
        while ahead.working():
            assert time.monotonic() - waited < 60
            time.sleep(0.01)
        ahead.begin(tmp_path, dict(name="tape", texture=None, seed=0, impasto=True), torch.rand(3, *ASPECT), "white",
                    RENDER, ANIMATION, FRAMES, 30)
        ahead.add(strokes_of(get_brush("tape")))
        assert ahead.working()
        while ahead.working():
            assert time.monotonic() - waited < 60
            time.sleep(0.01)
        ahead.process.kill()
        ahead.process.wait()
        ahead.add(strokes_of(get_brush("tape")))
        assert not ahead.working()  # it has ended: the painter need not leave it a core
    finally:
        ahead.close()


def _files_process_of(command: int) -> bool:
    """Whether a process writing files ahead for the process ``command`` runs (Linux's /proc)."""
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            words = cmdline.read_bytes().split(b"\0")  # python -m nsp.painter.ahead COMMAND FD
            if b"nsp.painter.ahead" in words and words[words.index(b"nsp.painter.ahead") + 1] == str(command).encode():
                return True
        except OSError:  # ended while looked at
            pass
    return False


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="finds processes in Linux's /proc")
def test_ctrl_c_while_a_painting_writes_ahead_keeps_what_was_painted_and_ends_the_files_process(tmp_path):
    run = tmp_path / "run"
    painting = subprocess.Popen([sys.executable, "-m", "nsp.paint", "strokes=300", "work_size=64", "render_size=128",
                                 "progress=false", f"hydra.run.dir={run}"], stderr=subprocess.PIPE, text=True)
    waited = time.monotonic()
    while not any(b"canvas" in event.read_bytes() for event in run.glob("events.out.tfevents.*")):  # a level is done
        assert painting.poll() is None and time.monotonic() - waited < 120
        time.sleep(0.02)
    assert _files_process_of(painting.pid)
    painting.send_signal(signal.SIGINT)
    _, err = painting.communicate(timeout=60)
    assert painting.returncode == INTERRUPTED, err
    assert f"interrupted: strokes.json and final.png of what was painted in {run}" in err
    assert 0 < len(load_strokes(run / "strokes.json").strokes) < 300
    assert not (run / "metrics.json").exists() and not list(run.glob(".*.tmp*"))
    assert not _files_process_of(painting.pid)


def test_a_painting_that_cannot_start_the_files_process_writes_them_itself(tmp_path, capsys, monkeypatch):
    from test_catalogue import run_cli

    def refused(*args, **kwargs):
        raise OSError(errno.EAGAIN, "Resource temporarily unavailable")

    monkeypatch.setattr(subprocess, "Popen", refused)
    run = tmp_path / "run"
    code, err = run_cli("nsp.paint", [f"strokes={AHEAD_STROKES}", "work_size=32", f"render_size={RENDER}",
                                      f"animation_size={ANIMATION}", "progress=false", "schedule.steps_per_stroke=1",
                                      "schedule.polish=0", f"hydra.run.dir={run}"], capsys, monkeypatch)
    assert code == 0, err
    assert "no process to write the files in while painting (Resource temporarily unavailable)" in (run / "paint.log").read_text()
    assert all((run / name).is_file() for name in FILES)
