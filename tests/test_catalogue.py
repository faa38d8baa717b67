"""The bad-input catalogue: every case runs a real entry point in-process (its ``cli()``: the command
line checks, Hydra, the work) and must end with one line ``error: …`` naming the bad value, exit
status 2, no traceback, and no file of a run written (nothing of a previous run lost).

``docs/robustness.md`` gives the counts; ``python -m pytest tests/test_catalogue.py -q`` recounts them.
"""
from __future__ import annotations

import importlib
import json
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from nsp.brushes import BRUSHES
from nsp.io.strokes import StrokeFile, save_strokes

RESULTS = ("final.png", "strokes.json", "painting.svg", "animation.gif", "metrics.json", "checkpoints", "out.png")

PAINT = [  # (case id, overrides, words the one line must contain)
    ("image missing", ["image=missing.jpg"], "image=missing.jpg: no such file"),
    ("image not an image", ["image={notes}"], "is not an image"),
    ("image a directory", ["image={tmp}"], "no such file"),
    ("strokes zero", ["strokes=0"], "strokes=0: expected a positive number"),
    ("strokes negative", ["strokes=-5"], "strokes=-5"),
    ("strokes not a number", ["strokes=abc"], "strokes=abc"),
    ("strokes fractional", ["strokes=1.5"], "strokes=1.5"),
    ("render_size zero", ["render_size=0"], "render_size=0"),
    ("render_size beyond memory", ["render_size=200000"], "render_size=200000"),
    ("work_size zero", ["work_size=0"], "work_size=0"),
    ("work_size one pixel", ["work_size=1"], "work_size=1"),
    ("animation_size zero", ["animation_size=0"], "animation_size=0"),
    ("animation_frames zero", ["animation_frames=0"], "animation_frames=0"),
    ("background not a colour", ["background=blue-ish"], "background=blue-ish is not a colour"),
    ("background short hex", ["background=#12345"], "#12345"),
    ("brush unknown", ["brush=oil"], "brush=oil: no such brush"),
    ("brush texture missing", ["brush.texture=/nonexistent/paper.png"], "/nonexistent/paper.png"),
    ("brush texture not an image", ["brush.texture={notes}"], "notes.txt"),
    ("neural without checkpoint", ["renderer=neural"], "renderer.checkpoint=PATH"),
    ("neural checkpoint missing", ["renderer=neural", "renderer.checkpoint=/nonexistent.ckpt"], "/nonexistent.ckpt"),
    ("neural checkpoint not one", ["renderer=neural", "renderer.checkpoint={notes}"], "is not an nsp renderer checkpoint"),
    ("renderer unknown", ["renderer=magic"], "renderer=magic"),
    ("softness zero", ["renderer.softness=0"], "renderer.softness=0"),
    ("softness not a number", ["renderer.softness=x"], "renderer.softness=x"),
    ("block_size zero", ["renderer.block_size=0"], "renderer.block_size=0"),
    ("schedule unknown", ["schedule=nope"], "schedule=nope"),
    ("grids with zero", ["schedule.grids=[1,0]"], "schedule.grids=[1, 0]"),
    ("grids empty", ["schedule.grids=[]"], "schedule.grids=[]"),
    ("init_size reversed", ["schedule.init_size=[0.5,0.1]"], "schedule.init_size=[0.5, 0.1]"),
    ("init_size one number", ["schedule.init_size=[0.5]"], "schedule.init_size=[0.5]"),
    ("steps_per_stroke negative", ["schedule.steps_per_stroke=-1"], "schedule.steps_per_stroke=-1"),
    ("overlap negative", ["schedule.overlap=-1"], "schedule.overlap=-1"),
    ("detail_side negative", ["schedule.detail_side=-8"], "schedule.detail_side=-8"),
    ("polish negative", ["schedule.polish=-2"], "schedule.polish=-2"),
    ("max_per_block zero", ["schedule.max_per_block=0"], "schedule.max_per_block=0"),
    ("loss unknown", ["loss=nope"], "loss=nope"),
    ("loss weight negative", ["loss.ot=-1"], "loss.ot=-1"),
    ("ot grid zero", ["loss=l1_ot", "loss.ot_grid=0"], "loss.ot_grid=0"),
    ("optimizer unknown", ["optimizer=nope"], "optimizer=nope"),
    ("learning rate negative", ["optimizer.lr=-1"], "optimizer.lr=-1"),
    ("style image missing", ["style.image=/nonexistent/style.jpg"], "/nonexistent/style.jpg"),
    ("style mode unknown", ["style.mode=nope"], "style.mode=nope"),
    ("style steps negative", ["style.steps=-1"], "style.steps=-1"),
    ("style size zero", ["style.size=0"], "style.size=0"),
    ("style weight negative", ["style.weight=-1"], "style.weight=-1"),
    ("seed not a number", ["seed=abc"], "seed=abc"),
    ("threads negative", ["threads=-1"], "threads=-1"),
    ("key misspelt", ["strokse=3"], "Did you mean 'strokes'"),
    ("nested key misspelt", ["schedule.max_per_blok=3"], "Did you mean 'schedule.max_per_block'"),
    ("growth below one", ["schedule.growth=0.5"], "schedule.growth=0.5"),
    ("candidates zero", ["schedule.candidates=0"], "schedule.candidates=0"),
    ("device unknown", ["device=gpu"], "device=gpu"),
    ("device beyond the GPUs here", ["device=cuda:7"], "device=cuda:7"),
    ("crowd below one", ["schedule.crowd=0"], "schedule.crowd=0"),
    ("experiment unknown", ["experiment=nope"], "experiment=nope"),
    ("unreadable override", ["strokes=[1,"], "strokes=[1,"),
    ("run dir holds a run", ["hydra.run.dir={previous}"], "already holds a run"),
]

TRAIN = [
    ("renderer unknown", ["renderer=magic"], "renderer=magic"),
    ("brush unknown", ["brush=oil"], "brush=oil"),
    ("size not offered", ["model.size=48"], "48"),
    ("size not a number", ["model.size=abc"], "model.size=abc"),
    ("renderer and data sizes differ", ["renderer.size=64"], "renderer.size=64 differs from model.size=32"),
    ("channel_mult zero", ["model.channel_mult=0"], "model.channel_mult=0"),
    ("batch_size zero", ["data.batch_size=0"], "data.batch_size=0"),
    ("epoch_size zero", ["data.epoch_size=0"], "data.epoch_size=0"),
    ("epoch under a batch", ["data.epoch_size=10", "data.batch_size=64"], "data.epoch_size=10"),
    ("val_size zero", ["data.val_size=0"], "data.val_size=0"),
    ("test_size zero", ["data.test_size=0"], "data.test_size=0"),
    ("num_workers negative", ["data.num_workers=-1"], "data.num_workers=-1"),
    ("learning rate zero", ["model.optimizer.lr=0"], "model.optimizer.lr=0"),
    ("max_steps zero", ["trainer.max_steps=0"], "trainer.max_steps=0"),
    ("max_steps not a number", ["trainer.max_steps=many"], "trainer.max_steps=many"),
    ("key misspelt", ["trainer.max_epoch=3"], "Did you mean 'trainer.max_epochs'"),
    ("lr_schedule unknown", ["lr_schedule=nope"], "lr_schedule=nope"),
    ("preset unknown", ["preset=huge"], "preset=huge"),
    ("experiment unknown", ["experiment=nope"], "experiment=nope"),
    ("texture missing", ["brush=oilpaint", "brush.texture=/nonexistent/paper.png"], "/nonexistent/paper.png"),
    ("checkpoint missing", ["ckpt_path=/nonexistent/last.ckpt"], "/nonexistent/last.ckpt"),
    ("checkpoint not one", ["ckpt_path={notes}"], "is not an nsp renderer checkpoint"),
    ("checkpoint truncated", ["ckpt_path={cut}"], "is not an nsp renderer checkpoint"),
    ("checkpoint random bytes", ["ckpt_path={noise}"], "is not an nsp renderer checkpoint"),
    ("checkpoint of another brush", ["brush=watercolor", "ckpt_path={ckpt}"], "brush=tape"),
    ("checkpoint of another renderer", ["renderer=dual", "ckpt_path={ckpt}"], "renderer=dcgan"),
    ("accelerator absent", ["trainer.accelerator=tpu"], "trainer.accelerator=tpu"),
    ("run dir holds a run", ["hydra.run.dir={previous}"], "already holds a run"),
]
PAINT_BASE = ["strokes=4", "work_size=32", "render_size=64", "animation_size=32", "progress=false"]
TRAIN_BASE = ["renderer=dcgan", "brush=tape", "model.size=32", "model.channel_mult=0.125", "data.batch_size=8",
              "data.epoch_size=16", "data.val_size=8", "data.test_size=8", "data.num_workers=0", "trainer.max_steps=1",
              "trainer.enable_progress_bar=false"]


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, str]:
    """The files the cases point at: a text file, checkpoints good and broken, a finished run."""
    tmp = tmp_path_factory.mktemp("catalogue")
    (tmp / "notes.txt").write_text("not a picture, not a checkpoint")
    previous = tmp / "previous"
    previous.mkdir()
    (previous / "final.png").write_bytes(b"a painting")
    from test_training import compose_train  # a real checkpoint of dcgan on tape, 32 px

    from nsp.training.run import train

    train(compose_train(tmp / "trained", "renderer=dcgan", "brush=tape", "trainer.max_steps=1", "data.num_workers=0"))
    ckpt = tmp / "trained" / "checkpoints" / "last.ckpt"
    (tmp / "cut.ckpt").write_bytes(ckpt.read_bytes()[:2000])
    (tmp / "noise.ckpt").write_bytes(np.random.default_rng(0).bytes(4000))
    painting = tmp / "painting.json"
    save_strokes(painting, StrokeFile(BRUSHES["tape"], torch.rand(3, 8, generator=torch.Generator().manual_seed(0)), 48, 64))
    data = json.loads(painting.read_text())
    data["strokes"][1]["x"] = float("nan")
    (tmp / "nan.json").write_text(json.dumps(data))
    save_strokes(tmp / "oil.json", StrokeFile(BRUSHES["oilpaint"], torch.rand(3, 11, generator=torch.Generator().manual_seed(0)), 48, 64))
    (tmp / "vast.json").write_text(painting.read_text().replace('"height": 48', f'"height": {10**400}'))
    (tmp / "notes.json").write_text("not JSON {")
    (tmp / "listed.json").write_text("[1, 2, 3]")
    np.savez(tmp / "ref.npz", x_ctt=np.full((1, 2, 8), np.nan, np.float32), x_color=np.zeros((1, 2, 6), np.float32),
             x_alpha=np.ones((1, 2, 1), np.float32))
    return {"notes": str(tmp / "notes.txt"), "tmp": str(tmp), "previous": str(previous), "ckpt": str(ckpt),
            "cut": str(tmp / "cut.ckpt"), "noise": str(tmp / "noise.ckpt"), "painting": str(painting),
            "notes_json": str(tmp / "notes.json"), "listed": str(tmp / "listed.json"), "nan": str(tmp / "nan.json"),
            "npz": str(tmp / "ref.npz"), "oil": str(tmp / "oil.json"), "vast": str(tmp / "vast.json")}


def run_cli(module: str, argv: list[str], capsys, monkeypatch) -> tuple[int, str]:
    """``python -m module *argv`` in this process: its exit status and what it wrote to stderr."""
    monkeypatch.setattr(sys, "argv", [module, *argv])
    monkeypatch.setenv("HYDRA_FULL_ERROR", "0")
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    threads = torch.get_num_threads()
    capsys.readouterr()
    try:
        importlib.import_module(module).cli()
        code = 0
    except SystemExit as exit:
        code = exit.code if isinstance(exit.code, int) else 1
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
        torch.set_num_threads(threads)
    return code, capsys.readouterr().err


def check(module: str, argv: list[str], words: str, run_dir: Path, capsys, monkeypatch) -> None:
    before = {p: p.stat().st_mtime_ns for p in run_dir.rglob("*")} if run_dir.exists() else {}
    code, err = run_cli(module, argv, capsys, monkeypatch)
    lines = err.strip().splitlines()
    assert "Traceback" not in err, err
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), err
    assert words in lines[0], lines[0]
    written = {p.name for p in run_dir.iterdir()} & set(RESULTS) if run_dir.exists() else set()
    assert written <= {p.name for p in before}, f"wrote {written}"
    assert all(p.stat().st_mtime_ns == t for p, t in before.items() if p.exists() and p.name in RESULTS)


def in_run_dir(overrides: list[str], files: dict[str, str], tmp_path: Path) -> tuple[list[str], Path]:
    """A case's command line with its files filled in, and the run dir it writes to (a fresh one,
    unless the case names the finished run's)."""
    argv = [o.format(**files) for o in overrides]
    if any(a.startswith("hydra.run.dir") for a in argv):
        return argv, Path(files["previous"])
    return [*argv, f"hydra.run.dir={tmp_path / 'run'}"], tmp_path / "run"


@pytest.mark.parametrize(("case", "overrides", "words"), PAINT, ids=[case for case, _, _ in PAINT])
def test_paint(case, overrides, words, files, tmp_path, capsys, monkeypatch):
    argv, run_dir = in_run_dir(overrides, files, tmp_path)
    small = [d for d in PAINT_BASE if d.split("=")[0] not in {a.split("=")[0] for a in argv}]  # fast if a check misses
    check("nsp.paint", [*small, *argv], words, run_dir, capsys, monkeypatch)


@pytest.mark.parametrize(("case", "overrides", "words"), TRAIN, ids=[case for case, _, _ in TRAIN])
def test_train(case, overrides, words, files, tmp_path, capsys, monkeypatch):
    argv, run_dir = in_run_dir(overrides, files, tmp_path)
    check("nsp.train", [*TRAIN_BASE, *argv], words, run_dir, capsys, monkeypatch)


RENDER = [
    ("strokes missing", ["strokes=/nonexistent/strokes.json", "out={tmp}/r/out.png"], "/nonexistent/strokes.json"),
    ("strokes not given", ["out={tmp}/r/out.png"], "strokes= is required"),
    ("out not given", ["strokes={painting}"], "out= is required"),
    ("strokes not JSON", ["strokes={notes_json}", "out={tmp}/r/out.png"], "notes.json"),
    ("strokes a list", ["strokes={listed}", "out={tmp}/r/out.png"], "listed.json"),
    ("strokes NaN", ["strokes={nan}", "out={tmp}/r/out.png"], "nan.json"),
    ("npz without brush", ["strokes={npz}", "out={tmp}/r/out.png"], "brush="),
    ("npz NaN", ["strokes={npz}", "brush=watercolor", "out={tmp}/r/out.png"], "NaN"),
    ("out a folder", ["strokes={painting}", "out={tmp}"], "is a folder"),
    ("out extension unknown", ["strokes={painting}", "out={tmp}/r/out.bmp"], "out.bmp"),
    ("out folder impossible", ["strokes={painting}", "out={notes}/out.png"], "cannot make its folder"),
    ("size zero", ["strokes={painting}", "size=0", "out={tmp}/r/out.png"], "size=0"),
    ("size not a number", ["strokes={painting}", "size=abc", "out={tmp}/r/out.png"], "size=abc"),
    ("size under the least", ["strokes={painting}", "size=8", "out={tmp}/r/out.png"], "size=8: expected a whole number of pixels from 16"),
    ("size of 400 digits", ["strokes={painting}", f"size={10**400}", "out={tmp}/r/out.png"], "size=an integer of over 39 digits"),
    ("size beyond memory", ["strokes={painting}", "size=10000000", "out={tmp}/r/out.png"], "size=10000000"),
    ("SVG beyond memory", ["strokes={oil}", "size=10000000", "out={tmp}/r/out.svg"], "size=10000000: a 10000000×7500000 render"),
    ("canvas of 400 digits", ["strokes={vast}", "out={tmp}/r/out.png"], "height a 401-digit number"),
    ("background not a colour", ["strokes={painting}", "background=blue-ish", "out={tmp}/r/out.png"], "blue-ish"),
    ("brush unknown", ["strokes={npz}", "brush=oil", "out={tmp}/r/out.png"], "brush=oil"),
    ("key misspelt", ["strokes={painting}", "sise=64", "out={tmp}/r/out.png"], "Did you mean 'size'"),
    ("device unknown", ["strokes={painting}", "device=gpu", "out={tmp}/r/out.png"], "device=gpu"),
    ("device beyond the GPUs here", ["strokes={painting}", "device=cuda:7", "out={tmp}/r/out.png"], "device=cuda:7"),
]


@pytest.mark.parametrize(("case", "argv", "words"), RENDER, ids=[case for case, _, _ in RENDER])
def test_render(case, argv, words, files, capsys, monkeypatch):
    check("nsp.render", [a.format(**files) for a in argv], words, Path(files["tmp"]) / "r", capsys, monkeypatch)


def test_a_refused_paintings_log_ends_with_its_error_line(tmp_path, capsys, monkeypatch):
    code, err = run_cli("nsp.paint", [*PAINT_BASE, "strokes=0", f"hydra.run.dir={tmp_path}"], capsys, monkeypatch)
    assert code == 2 and err.strip() == "error: strokes=0: expected a positive number"
    first, last = (tmp_path / "paint.log").read_text().strip().splitlines()
    assert first.endswith("painting astronaut with 0 oilpaint strokes…") and last.endswith(f"ERROR] - {err.strip()}")


REPORT = [
    ("dir missing", ["{tmp}/nowhere"], "nowhere"),
    ("dir is a file", ["{notes}"], "notes.txt"),
    ("dir holds no runs", ["{empty}"], "empty"),
]


@pytest.mark.parametrize(("case", "argv", "words"), REPORT, ids=[case for case, _, _ in REPORT])
def test_report(case, argv, words, files, tmp_path, capsys, monkeypatch):
    (tmp_path / "empty").mkdir()
    argv = [a.format(**files, empty=tmp_path / "empty") for a in argv]
    check("nsp.report", argv, words, tmp_path / "empty", capsys, monkeypatch)
