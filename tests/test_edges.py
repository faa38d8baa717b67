"""The second catalogue: runs at the edges of the machine and of the files they are given.

Run dirs where none can be made (under a file, a file itself, a read-only disk), a disk that fills
while a painting or a sweep writes, sizes past the memory there is, checkpoints whose settings do not
fit their weights, stroke files nested or numbered past reason. Each case runs a real entry point
in-process and must end in one line ``error: …`` naming the problem, no traceback, and nothing that
was written lost. ``docs/robustness.md`` gives the counts.
"""
from __future__ import annotations

import copy
import errno
import json
import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import pytest
import torch
from test_catalogue import PAINT_BASE, TRAIN_BASE, run_cli

import nsp.files
import nsp.io.export
from nsp.files import remove_temporaries
from nsp.io.strokes import StrokeFileError, load_strokes

BAD_INPUT, FAILED = 2, 1


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert "Traceback" not in err, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


def last_line(err: str) -> str:
    assert "Traceback" not in err, err
    return err.strip().splitlines()[-1]


# Run dirs -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("module", ["nsp.paint", "nsp.train"])
@pytest.mark.parametrize("where", ["under a file", "a file"])
def test_a_run_dir_that_cannot_be_made_is_one_line(module, where, tmp_path, capsys, monkeypatch):
    (tmp_path / "taken").write_text("someone's notes")
    run_dir = tmp_path / "taken" / "run" if where == "under a file" else tmp_path / "taken"
    base = PAINT_BASE if module == "nsp.paint" else TRAIN_BASE
    code, err = run_cli(module, [*base, f"hydra.run.dir={run_dir}"], capsys, monkeypatch)
    assert code == BAD_INPUT
    assert f"hydra.run.dir={run_dir}: cannot make a run dir there" in one_line(err)
    assert (tmp_path / "taken").read_text() == "someone's notes"


def test_a_sweep_dir_under_a_file_is_one_line(tmp_path, capsys, monkeypatch):
    (tmp_path / "taken").write_text("")
    code, err = run_cli("nsp.paint", ["-m", *PAINT_BASE, "seed=0,1", f"hydra.sweep.dir={tmp_path / 'taken' / 'sweep'}"],
                        capsys, monkeypatch)
    assert code == BAD_INPUT and "cannot make a run dir there (Not a directory)" in one_line(err)


def test_a_run_dir_on_a_read_only_disk_is_one_line(tmp_path, capsys, monkeypatch):
    read_only = tmp_path / "mounted"
    read_only.mkdir()
    mkdir = Path.mkdir

    def refuse(self, *args, **kwargs):  # as a read-only filesystem answers, whoever runs the test (root too)
        if read_only in (path := self.absolute(), *path.parents):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(self))
        return mkdir(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", refuse)
    monkeypatch.chdir(read_only)
    for run in ([f"hydra.run.dir={read_only / 'run'}"], []):  # a named dir, and the default one under the cwd
        code, err = run_cli("nsp.paint", [*PAINT_BASE, *run], capsys, monkeypatch)
        assert code == BAD_INPUT and "cannot make a run dir there (Read-only file system)" in one_line(err)
    assert not any(read_only.iterdir())


# Full disks -----------------------------------------------------------------------------------------

@contextmanager
def full_disk(monkeypatch, *names: str):
    """Every nsp file named ``names`` (all, if none) fails to write as on a full disk."""
    atomic_path = nsp.files.atomic_path

    @contextmanager
    def refused(path):
        if not names or Path(path).name in names:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        with atomic_path(path) as temporary:
            yield temporary

    for module in (nsp.files, nsp.io.export):  # JSON, and the pictures
        monkeypatch.setattr(module, "atomic_path", refused)
    yield
    for module in (nsp.files, nsp.io.export):
        monkeypatch.setattr(module, "atomic_path", atomic_path)


def test_a_disk_that_fills_while_a_painting_writes_keeps_what_was_written(tmp_path, capsys, monkeypatch):
    with full_disk(monkeypatch, "painting.svg", "animation.gif"):
        code, err = run_cli("nsp.paint", [*PAINT_BASE, f"hydra.run.dir={tmp_path}"], capsys, monkeypatch)
    assert code == FAILED
    line = last_line(err)
    assert line.startswith(f"error: No space left on device while writing into {tmp_path}; the run stopped, keeping ")
    assert "final.png" in line and "strokes.json" in line
    assert len(load_strokes(tmp_path / "strokes.json").strokes) == 4  # whole, readable
    assert not list(tmp_path.glob(".*.tmp*"))
    assert (tmp_path / "paint.log").read_text().strip().splitlines()[-1].endswith(line)  # the run's log says it too


def test_a_disk_that_fills_while_painting_from_python_is_one_line(tmp_path, monkeypatch):
    from nsp.api import paint
    from nsp.errors import RunFailed

    with full_disk(monkeypatch, "painting.svg", "animation.gif"), pytest.raises(RunFailed) as failed:
        paint("astronaut", out=tmp_path, strokes=4, work_size=32, render_size=64, animation_size=32, progress=False)
    message = str(failed.value)
    assert message.startswith(f"No space left on device while writing into {tmp_path}; the run stopped, keeping ")
    assert "final.png" in message and "strokes.json" in message and "\n" not in message
    assert len(load_strokes(tmp_path / "strokes.json").strokes) == 4 and not list(tmp_path.glob(".*.tmp*"))


def test_a_sweep_on_a_full_disk_ends_with_one_line_even_when_no_job_can_record(tmp_path, capsys, monkeypatch):
    with full_disk(monkeypatch):
        code, err = run_cli("nsp.paint", ["-m", *PAINT_BASE, "seed=0,1", "hydra/launcher=basic", f"hydra.sweep.dir={tmp_path}"],
                            capsys, monkeypatch)  # in this process, where the disk is mocked
    assert code == FAILED and "Traceback" not in err
    assert "error: 0_astronaut_oilpaint: could not record its status (No space left on device)" in err
    assert last_line(err).startswith("2 of 2 jobs failed (0_astronaut_oilpaint, 1_astronaut_oilpaint)")


@pytest.fixture
def small_disk(tmpfs):
    """A 3-MB filesystem, 2.4 MB of it already taken."""
    (tmpfs / "taken").write_bytes(bytes(2400 * 1024))
    return tmpfs


@pytest.mark.parametrize("module", ["nsp.paint", "nsp.train"])
def test_a_real_full_disk_is_one_line_and_what_was_written_is_whole(module, small_disk, capsys, monkeypatch):
    argv = [*PAINT_BASE, "render_size=1024"] if module == "nsp.paint" else [*TRAIN_BASE, "trainer.max_steps=4"]
    if module == "nsp.train":
        (small_disk / "more").write_bytes(bytes(300 * 1024))  # room for one 200-kB checkpoint, not two
    code, err = run_cli(module, [*argv, f"hydra.run.dir={small_disk / 'run'}"], capsys, monkeypatch)
    assert code == FAILED and "No space left on device" in last_line(err) and last_line(err).startswith("error: ")
    if module == "nsp.paint":
        check_whole(small_disk / "run")
    for checkpoint in (small_disk / "run").rglob("*.ckpt"):
        torch.load(checkpoint, weights_only=True)


# Memory ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("module", "argv", "words"), [
    ("nsp.paint", ["work_size=65536"], "work_size=65536: a 65536×65536 working canvas needs about"),
    ("nsp.paint", ["style.image=chelsea", "style.backbone=random", "style.size=65536"],
     "style.size=65536: a 65536×65536 styled canvas needs about"),
    ("nsp.paint", ["style.image=chelsea", "style.mode=color", "style.size=65536"], "style.size=65536: a 65536×65536"),
    ("nsp.train", ["data.batch_size=2000000", "data.epoch_size=2000000"],
     "data.batch_size=2000000: training on batches of 32-px strokes needs about"),
    ("nsp.train", ["data.val_size=900000000"], "data.val_size + data.test_size = 900000008: keeping that many"),
], ids=["work_size", "style.size full", "style.size color", "batch_size", "val_size"])
def test_sizes_past_the_memory_there_is_are_refused_naming_one_that_fits(module, argv, words, tmp_path, capsys, monkeypatch):
    base = PAINT_BASE if module == "nsp.paint" else TRAIN_BASE
    code, err = run_cli(module, [*base, *argv, f"hydra.run.dir={tmp_path}"], capsys, monkeypatch)
    line = one_line(err)
    assert code == BAD_INPUT and words in line and ("the largest that fits is about" in line or "keep their sum under" in line)
    assert not (tmp_path / "final.png").exists() and not (tmp_path / "checkpoints").exists()


# Checkpoints ----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory) -> Path:
    from test_training import compose_train

    from nsp.training.run import train

    out = tmp_path_factory.mktemp("trained")
    train(compose_train(out, *(o for o in TRAIN_BASE if not o.startswith("trainer.enable"))))
    return out / "checkpoints" / "last.ckpt"


def edited(checkpoint: Path, tmp_path: Path, edit) -> Path:
    ckpt = copy.deepcopy(torch.load(checkpoint, weights_only=True))
    edit(ckpt)
    torch.save(ckpt, tmp_path / "edited.ckpt")
    return tmp_path / "edited.ckpt"


EDITS = {
    "settings that do not fit the weights": (lambda c: c["hyper_parameters"]["renderer"].update(channel_mult=0.5), "size mismatch"),
    "a key the renderer does not take": (lambda c: c["hyper_parameters"]["renderer"].update(blur=1), "unexpected keyword argument 'blur'"),
    "no weights": (lambda c: c.update(state_dict={}), "Missing key(s)"),
    "an unknown brush": (lambda c: c["hyper_parameters"].update(brush="charcoal"), "unknown brush 'charcoal'"),
}


@pytest.mark.parametrize("case", EDITS)
def test_a_painting_with_an_edited_checkpoint_is_one_line(case, checkpoint, tmp_path, capsys, monkeypatch):
    edit, words = EDITS[case]
    path = edited(checkpoint, tmp_path, edit)
    code, err = run_cli("nsp.paint", [*PAINT_BASE, "brush=tape", "renderer=neural", f"renderer.checkpoint={path}",
                                      f"hydra.run.dir={tmp_path / 'run'}"], capsys, monkeypatch)
    line = one_line(err)
    assert code == BAD_INPUT and str(path) in line and words in line


def test_resuming_with_another_channel_width_is_one_line_naming_the_saved_one(checkpoint, tmp_path, capsys, monkeypatch):
    argv = [o if not o.startswith("model.channel_mult") else "model.channel_mult=0.25" for o in TRAIN_BASE]
    code, err = run_cli("nsp.train", [*argv, f"ckpt_path={checkpoint}", f"hydra.run.dir={tmp_path}"], capsys, monkeypatch)
    assert code == BAD_INPUT
    assert one_line(err) == f"error: ckpt_path={checkpoint} was trained with model.channel_mult=0.125; this run differs: resume with those"


# Stroke files past reason ---------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "words"), [
    ('{"format": "nsp-strokes", "x": ' + "[" * 50_000 + "]" * 50_000 + "}", "nested too deep"),
    ('{"format": "nsp-strokes", "version": 1' + "0" * 5000 + "}", "is not valid JSON"),
], ids=["nested 50000 deep", "5000-digit integer"])
def test_stroke_files_past_reason_are_one_line(text, words, tmp_path):
    path = tmp_path / "strokes.json"
    path.write_text(text)
    with pytest.raises(StrokeFileError, match=words) as error:
        load_strokes(path)
    assert "\n" not in str(error.value) and len(str(error.value)) < 300


# kill -9 ---------------------------------------------------------------------------------------------

def _ended() -> int:
    """The id of a process that has ended."""
    process = subprocess.Popen(["true"])
    process.wait()
    return process.pid


def test_what_a_killed_writer_left_is_removed_by_the_next_and_a_running_ones_kept(tmp_path):
    from nsp.files import remove_leftovers
    from nsp.files import write_json

    gone, alive = _ended(), os.getpid()
    for pid in (gone, alive):
        (tmp_path / f".metrics.{pid}-0a1b2c3d.tmp.json").write_text('{"cut sh')
    (tmp_path / f".compiling-{gone}-x1").mkdir()
    (tmp_path / f".compiling-{gone}-x1" / "kernel.so").write_bytes(b"\0")
    (tmp_path / f".compiling-{alive}-x2").mkdir()
    write_json(tmp_path / "metrics.json", {"status": "completed"})
    remove_leftovers(tmp_path, ".compiling-")
    assert sorted(p.name for p in tmp_path.iterdir()) == [f".compiling-{alive}-x2", f".metrics.{alive}-0a1b2c3d.tmp.json",
                                                          "metrics.json"]


def check_whole(run_dir: Path) -> set[str]:
    """The painting's files in ``run_dir``, each checked whole by reading it; returns their names."""
    from PIL import Image

    present = {p.name for p in run_dir.iterdir() if p.name in ("strokes.json", "final.png", "painting.svg", "animation.gif", "metrics.json")}
    if "strokes.json" in present:
        load_strokes(run_dir / "strokes.json")
    for name in ("final.png", "animation.gif"):
        if name in present:
            with Image.open(run_dir / name) as image:
                image.load()
    if "painting.svg" in present:
        assert (run_dir / "painting.svg").read_text().rstrip().endswith("</svg>")
    if "metrics.json" in present:
        json.loads((run_dir / "metrics.json").read_text())
    return present


@pytest.mark.parametrize("delay", [0.0, 0.15, 0.4])
def test_a_painting_killed_while_it_writes_leaves_each_file_whole_or_absent(delay, tmp_path):
    run = subprocess.Popen([sys.executable, "-m", "nsp.paint", "strokes=300", "work_size=64", "render_size=640",
                            "animation_size=320", "progress=false", f"hydra.run.dir={tmp_path}"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for line in run.stdout:
        if line.startswith("writing final.png"):
            break
    time.sleep(delay)
    run.kill()
    run.wait()
    present = check_whole(tmp_path)
    assert "strokes.json" in present or not present  # the painting itself is the first file written
    if "strokes.json" in present:  # a render of what was kept, into the same folder
        rerun = subprocess.run([sys.executable, "-m", "nsp.render", f"strokes={tmp_path / 'strokes.json'}",
                                f"out={tmp_path / 'final.png'}", "size=64"], capture_output=True, text=True)
        assert rerun.returncode == 0, rerun.stderr
    else:
        remove_temporaries(tmp_path)  # what the next write into the folder does first
    assert not [p.name for p in tmp_path.glob(".*.tmp.*")]  # what the killed painting left is gone


def test_sigterm_during_the_final_test_pass_stops_at_once_keeping_the_final_step(tmp_path, capsys, monkeypatch):
    import pytorch_lightning as L

    test = L.Trainer.test

    def signalled(self, *args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)  # as `timeout` or Slurm would, while the test strokes are scored
        return test(self, *args, **kwargs)

    monkeypatch.setattr(L.Trainer, "test", signalled)
    code, err = run_cli("nsp.train", [*TRAIN_BASE, f"hydra.run.dir={tmp_path}"], capsys, monkeypatch)
    assert code == 130 and last_line(err) == (f"interrupted: resume with ckpt_path={tmp_path / 'checkpoints' / 'last.ckpt'} "
                                              f"hydra.run.dir={tmp_path}")
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["status"] == "interrupted" and metrics["steps"] == 1 and "test/psnr" not in metrics
    assert torch.load(tmp_path / "checkpoints" / "last.ckpt", weights_only=True)["global_step"] == 1
