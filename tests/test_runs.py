"""Runs that keep what they had: one run per dir, SIGTERM handled as Ctrl-C, exact resumes in place,
and command lines whose paths and colours need no quoting."""
import copy
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytorch_lightning as L
import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from omegaconf import OmegaConf, read_write
from PIL import Image
from test_training import compose_train

from nsp.cli import FAILED, INTERRUPTED, RunDirs, quote_text, run_job
from nsp.io.strokes import load_strokes
from nsp.painting.schema import PaintConfig  # noqa: F401  (registers ``paint_schema``)
from nsp.renderers.checkpoint import check_checkpoint
from nsp.training.run import train

ROOT = Path(__file__).parents[1]
TINY_PAINT = ["strokes=8", "work_size=48", "render_size=64", "animation_size=32", "progress=false"]
TINY_TRAIN = ["renderer=dcgan", "brush=tape", "data.num_workers=0"]


def foreground() -> None:
    """Ctrl-C as in a terminal's foreground job: a background shell job (CI) inherits SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def command(name: str, *args: str, cwd: Path = ROOT) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", name, *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=foreground)


def wait_for(path: Path, process: subprocess.Popen, timeout: float = 120) -> None:
    """Until ``path`` (its name may be a glob pattern) exists, while ``process`` runs."""
    deadline = time.monotonic() + timeout
    while not any(path.parent.glob(path.name)):
        assert process.poll() is None, process.communicate()[1]
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.2)


def test_a_named_dir_that_holds_a_run_is_refused_before_anything_is_written(tmp_path):
    first = command("nsp.paint", *TINY_PAINT, f"hydra.run.dir={tmp_path}")
    assert first.wait(timeout=300) == 0
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    second = command("nsp.paint", *TINY_PAINT, "seed=1", f"hydra.run.dir={tmp_path}")
    assert second.wait(timeout=300) == 2
    assert second.stderr.read().strip() == f"error: hydra.run.dir={tmp_path} already holds a run; name a new dir, or remove that one first"
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")} == before


def test_a_run_refused_at_start_leaves_no_dir_that_looks_like_a_run(tmp_path):
    for name, args in (("nsp.train", ["trainer.accelerator=gpu"]), ("nsp.paint", ["image=/nonexistent.png"])):
        run = command(name, *args, cwd=tmp_path)  # into its default dir, outputs/<command>/<time>_…
        assert run.wait(timeout=300) == 2 and run.stderr.read().startswith("error: ")
        assert not list((tmp_path / "outputs" / name.split(".")[1]).iterdir())
    named = tmp_path / "mine"
    named.mkdir()  # a dir the user named may have been theirs before: it stays
    assert command("nsp.paint", "image=/nonexistent.png", f"hydra.run.dir={named}").wait(timeout=300) == 2 and named.is_dir()


def test_a_named_dir_is_claimed_so_two_runs_started_together_never_share_it(tmp_path):
    import os

    def named(path: Path):
        with initialize_config_dir(str(ROOT / "conf" / "paint"), version_base="1.3"):
            return compose("paint", overrides=[f"hydra.run.dir={path}"], return_hydra_config=True)

    cfg = named(tmp_path / "run")
    RunDirs().on_run_start(copy.deepcopy(cfg))  # this process takes it, for the rest of its life
    assert (tmp_path / "run" / ".nsp-run").read_text() == str(os.getpid())
    with pytest.raises(SystemExit) as refused:  # a second run while the first still goes
        RunDirs().on_run_start(copy.deepcopy(cfg))
    assert refused.value.code == 2
    for pid in ("1", str(os.getppid()), "999999999"):  # a container's pid 1, a live process that is no run, one that ended
        (tmp_path / pid).mkdir()
        (tmp_path / pid / ".nsp-run").write_text(pid)  # left by a run that has ended: nothing holds it
        RunDirs().on_run_start(named(tmp_path / pid))
        assert (tmp_path / pid / ".nsp-run").read_text() == str(os.getpid())
        assert [p.name for p in (tmp_path / pid).iterdir()] == [".nsp-run"]
    HydraConfig.instance().cfg = None


def test_a_claim_is_free_once_its_process_has_ended_whatever_its_pid(tmp_path):
    """The claim is a lock the kernel releases when its process ends (even by ``kill -9``), not a
    process id to be checked: a pid reused, or 1 in a container, does not hold a dir forever."""
    run = tmp_path / "run"
    run.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", "import fcntl, os, sys, time\n"
                               f"f = os.open({str(run / '.nsp-run')!r}, os.O_RDWR | os.O_CREAT)\n"
                               "fcntl.flock(f, fcntl.LOCK_EX); os.write(f, b'1'); print('held', flush=True); time.sleep(300)"],
                              stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline() == "held\n"
    refused = command("nsp.paint", *TINY_PAINT, f"hydra.run.dir={run}")  # refused before torch loads
    assert refused.wait(timeout=120) == 2
    assert refused.stderr.read().strip() == f"error: hydra.run.dir={run} is taken by another run that is still going; name a new dir"
    holder.kill()
    holder.wait()
    assert (run / ".nsp-run").read_text() == "1"
    painting = command("nsp.paint", *TINY_PAINT, f"hydra.run.dir={run}")
    assert painting.wait(timeout=300) == 0, painting.stderr.read()
    assert len(load_strokes(run / "strokes.json").strokes) == 8


def test_of_two_paintings_started_together_into_one_named_dir_one_runs_and_one_is_refused(tmp_path):
    runs = [command("nsp.paint", *TINY_PAINT, f"seed={seed}", f"hydra.run.dir={tmp_path / 'run'}") for seed in (0, 1)]
    codes = sorted(run.wait(timeout=300) for run in runs)
    assert codes == [0, 2]
    assert len(load_strokes(tmp_path / "run" / "strokes.json").strokes) == 8


def test_default_dirs_are_claimed_once_so_runs_started_in_the_same_second_never_share_one(tmp_path):
    with initialize_config_dir(str(ROOT / "conf" / "paint"), version_base="1.3"):
        cfg = compose("paint", overrides=[], return_hydra_config=True)
    default = tmp_path / "outputs" / "12-00-00_oilpaint"
    dirs = []
    for _ in range(3):
        run = copy.deepcopy(cfg)
        with read_write(run):
            run.hydra.run.dir = str(default)
        RunDirs().on_run_start(run)
        dirs.append(run.hydra.run.dir)
    HydraConfig.instance().cfg = None
    assert dirs == [str(default), f"{default}_2", f"{default}_3"]
    assert all(Path(d).is_dir() for d in dirs)


def test_a_painting_imports_numpy_before_torch_so_a_ctrl_c_while_torch_loads_is_heard(tmp_path):
    # torch's own import of numpy swallows a KeyboardInterrupt raised inside it: the painting then ran to its end
    done = subprocess.run([sys.executable, "-X", "importtime", "-m", "nsp.paint", "strokes=1", "work_size=16",
                           "render_size=16", "animation_size=16", "progress=false", f"hydra.run.dir={tmp_path}"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    names = [line.rsplit("|", 1)[1] for line in done.stderr.splitlines() if line.startswith("import time:")]
    first_torch = next(i for i, name in enumerate(names) if name.strip().split(".")[0] == "torch")
    assert names.index(" numpy") < first_torch  # numpy imported whole, at the top level, before torch began


@pytest.mark.parametrize("signals", [[signal.SIGTERM], [signal.SIGINT], [signal.SIGINT, signal.SIGINT]],
                         ids=["SIGTERM", "Ctrl-C", "Ctrl-C twice"])
def test_a_signalled_painting_keeps_what_it_painted_and_exits_interrupted(signals, tmp_path):
    run = command("nsp.paint", "strokes=3000", "work_size=128", "progress=false", f"hydra.run.dir={tmp_path}")
    wait_for(tmp_path / "events.out.tfevents.*", run)
    time.sleep(3)  # some strokes in
    for sig in signals:  # the second while the first one's files are being written
        run.send_signal(sig)
        time.sleep(0.05)
    assert run.wait(timeout=120) == INTERRUPTED
    stderr = run.stderr.read()
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1] == f"interrupted: strokes.json and final.png of what was painted in {tmp_path}"
    assert 0 < len(load_strokes(tmp_path / "strokes.json").strokes) < 3000
    assert Image.open(tmp_path / "final.png").size == (1024, 1024)
    assert not list(tmp_path.glob("*.tmp*"))


def test_a_painting_shows_each_line_once_and_keeps_them_all_in_its_log(tmp_path):
    run = command("nsp.paint", *TINY_PAINT, f"hydra.run.dir={tmp_path}")
    out, err = run.communicate(timeout=300)
    assert run.returncode == 0, err
    lines = out.strip().splitlines()
    assert lines[0] == "painting astronaut with 8 oilpaint strokes…" and out.count(lines[0]) == 1  # before torch loads
    assert lines[1].startswith("writing final.png, strokes.json, painting.svg, animation.gif (9 frames)")
    assert lines[-1].startswith("painted 8 oilpaint strokes in ") and lines[-1].endswith(f"; {tmp_path}")
    log = (tmp_path / "paint.log").read_text()
    assert all(line in log for line in lines)


def test_sigterm_on_training_saves_the_stopping_step_and_exits_interrupted(tmp_path):
    run = command("nsp.train", *TINY_TRAIN, "model.channel_mult=0.125", "data.batch_size=8", "data.val_size=16", "data.test_size=16",
                  "trainer.max_steps=100000", "trainer.enable_progress_bar=false", f"hydra.run.dir={tmp_path}")
    wait_for(tmp_path / "checkpoints", run, timeout=180)  # the first validation is done: training runs
    run.send_signal(signal.SIGTERM)
    assert run.wait(timeout=120) == INTERRUPTED
    assert run.stderr.read().strip().splitlines()[-1] == (
        f"interrupted: resume with ckpt_path={tmp_path}/checkpoints/last.ckpt hydra.run.dir={tmp_path}")
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    saved = torch.load(tmp_path / "checkpoints" / "last.ckpt", weights_only=True)
    assert metrics["status"] == "interrupted" and saved["global_step"] == metrics["steps"] > 0


def test_a_resume_in_place_is_exact_across_a_stop_mid_epoch(tmp_path):
    class CtrlC(L.Callback):  # epochs of 4 batches: stop in the second one, after step 6's update
        def on_train_batch_end(self, trainer, *args):
            if trainer.global_step == 6:
                raise KeyboardInterrupt

    straight = train(compose_train(tmp_path / "straight", *TINY_TRAIN, "trainer.max_steps=10"))
    with pytest.raises(KeyboardInterrupt):
        train(compose_train(tmp_path / "stopped", *TINY_TRAIN, "trainer.max_steps=10"), callbacks=[CtrlC()])
    last = tmp_path / "stopped" / "checkpoints" / "last.ckpt"
    resumed = train(compose_train(tmp_path / "stopped", *TINY_TRAIN, "trainer.max_steps=10", f"ckpt_path={last}"))
    assert sorted(p.name for p in last.parent.iterdir()) == ["best.ckpt", "last.ckpt"]  # no last-v1.ckpt
    a, b = (torch.load(p / "checkpoints" / "last.ckpt", weights_only=True) for p in (tmp_path / "straight", tmp_path / "stopped"))
    assert a["global_step"] == b["global_step"] == 10
    assert all(torch.equal(a["state_dict"][k], b["state_dict"][k]) for k in a["state_dict"])
    assert resumed["val/psnr"] == straight["val/psnr"]


def test_a_signal_stops_training_between_steps_so_the_resume_is_exact_also_at_an_epoch_end(tmp_path):
    from nsp.training.run import StopBetweenSteps

    tiny = [*TINY_TRAIN, "model.channel_mult=0.125", "data.batch_size=8", "data.epoch_size=32", "data.val_size=16",
            "data.test_size=16", "trainer.max_steps=10"]
    straight = train(compose_train(tmp_path / "straight", *tiny))
    for step in (4, 6):  # epochs of 4 steps: at the end of the first (its validation still to come), and within one
        class Signal(L.Callback):  # Ctrl-C or SIGTERM arrives while this step runs
            def on_train_batch_end(self, trainer, *args):
                if trainer.global_step == step:
                    next(c for c in trainer.callbacks if isinstance(c, StopBetweenSteps))._ask(signal.SIGTERM, None)

        run = tmp_path / f"stopped_at_{step}"
        with pytest.raises(KeyboardInterrupt):
            train(compose_train(run, *tiny), callbacks=[Signal()])
        last = run / "checkpoints" / "last.ckpt"
        assert torch.load(last, weights_only=True)["global_step"] == step
        assert train(compose_train(run, *tiny, f"ckpt_path={last}"))["val/psnr"] == straight["val/psnr"]


def test_lightnings_own_sigterm_at_an_epoch_end_resumes_exactly(tmp_path):
    """Lightning's SIGTERM handler (beside nsp's) stops a run once an epoch is counted done, before the
    next begins: the checkpoint says so, and the resume trains that next epoch, as a run never stopped."""
    tiny = [*TINY_TRAIN, "model.channel_mult=0.125", "data.batch_size=8", "data.epoch_size=32", "data.val_size=16",
            "data.test_size=16", "trainer.max_steps=10"]
    straight = train(compose_train(tmp_path / "straight", *tiny))

    class Sigterm(L.Callback):  # heard during the first epoch's last step: Lightning raises once the epoch is done
        def on_train_epoch_end(self, trainer, *args):
            if trainer.current_epoch == 0:
                trainer._signal_connector.received_sigterm = True

    run = tmp_path / "stopped"
    with pytest.raises(KeyboardInterrupt):
        train(compose_train(run, *tiny), callbacks=[Sigterm()])
    last = run / "checkpoints" / "last.ckpt"
    assert torch.load(last, weights_only=True)["global_step"] == 4
    resumed = train(compose_train(run, *tiny, f"ckpt_path={last}"))
    assert resumed["steps"] == straight["steps"] == 10 and resumed["val/psnr"] == straight["val/psnr"]


def test_a_checkpoint_that_cannot_be_resumed_is_one_line(tmp_path):
    train(compose_train(tmp_path, *TINY_TRAIN, "trainer.max_steps=2"))
    good = tmp_path / "checkpoints" / "last.ckpt"
    (tmp_path / "cut.ckpt").write_bytes(good.read_bytes()[:1000])
    (tmp_path / "noise.ckpt").write_bytes(np.random.default_rng(0).bytes(5000))
    cases = {
        tmp_path / "missing.ckpt": "does not exist",
        tmp_path / "cut.ckpt": "is not an nsp renderer checkpoint",
        tmp_path / "noise.ckpt": "is not an nsp renderer checkpoint",
    }
    for path, message in cases.items():
        with pytest.raises(ValueError, match=message) as error:
            check_checkpoint(path, {"name": "dcgan", "size": 32}, "tape")
        assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="holds renderer=dcgan brush=tape model.size=32; this run is renderer=dual brush=tape"):
        check_checkpoint(good, {"name": "dual", "size": 32}, "tape")


@pytest.mark.parametrize("error", [
    MemoryError(),
    RuntimeError("[enforce fail at alloc_cpu.cpp:127] err == 0. DefaultCPUAllocator: can't allocate memory: you tried to "
                 "allocate 12582912 bytes. Error code 12 (Cannot allocate memory)"),  # torch under ulimit -v
    ImportError("libgfortran-8f1e9814.so.5.0.0: failed to map segment from shared object"),  # scipy's, likewise
    RuntimeError("can't start new thread"),  # ulimit -u
])
def test_a_limit_of_the_machine_ends_a_run_in_one_line_naming_what_it_kept(error, tmp_path, capsys):
    (tmp_path / "strokes.json").write_text("{}")
    (tmp_path / "paint.log").write_text("")

    def work(cfg):
        raise error

    with pytest.raises(SystemExit) as ended:
        run_job(OmegaConf.create({"output_dir": str(tmp_path)}), work)
    line = capsys.readouterr().err
    assert ended.value.code == FAILED and line.count("\n") == 1 and line.startswith("error: a limit of this machine")
    assert "kept paint.log, strokes.json" in line and (tmp_path / "strokes.json").is_file()
    with pytest.raises(ZeroDivisionError):  # a bug is no limit: its traceback stays
        run_job(OmegaConf.create({"output_dir": str(tmp_path)}), lambda cfg: 1 / 0)


def test_numpys_openblas_starts_no_threads_of_its_own_unless_the_user_asks():
    """Where a limit on processes refuses OpenBLAS a thread, it raises SIGINT (a run ended "interrupted",
    exit 130, under ``prlimit --nproc=4``): nsp leaves it one thread, so it starts none."""
    script = "import os, nsp, numpy; print(os.environ['OPENBLAS_NUM_THREADS'])"
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    for given, expected in ((None, "1"), ("2", "2")):
        told = env if given is None else env | {"OPENBLAS_NUM_THREADS": given}
        done = subprocess.run([sys.executable, "-c", script], env=told, capture_output=True, text=True, check=True)
        assert done.stdout.strip() == expected


def test_paths_and_colours_are_quoted_for_hydra_where_it_needs_it():
    assert quote_text(["background=#a0522d", "strokes=10", "image=~/my photo (1).jpg"], ["background", "image"]) == [
        "background='#a0522d'", "strokes=10", "image='~/my photo (1).jpg'"]
    assert quote_text(["image=a[1].png,b.png"], ["image"], sweep=True) == ["image='a[1].png','b.png'"]
    assert quote_text(["image=it's=é.png"], ["image"]) == ["image='it\\'s=é.png'"]
    assert quote_text(["image=plain.png"], ["image"]) == ["image=plain.png"]


@pytest.mark.parametrize("path", [r"C:\photos\a b.png", "/tmp/ends in\\", r"/tmp/x\'y (1).png", r"a\\b c"])
def test_a_quoted_path_reads_back_exactly_with_its_backslashes(path):
    from hydra.core.override_parser.overrides_parser import OverridesParser

    (quoted,) = quote_text([f"image={path}"], ["image"])
    assert OverridesParser.create().parse_override(quoted).value() == path


def test_a_painting_reads_an_unquoted_colour_and_an_awkward_path(tmp_path):
    photo = tmp_path / "été (1) [x]=~.png"
    Image.fromarray(np.full((20, 30, 3), 200, np.uint8)).save(photo)
    run = command("nsp.paint", *TINY_PAINT, f"image={photo}", "background=#a0522d", f"hydra.run.dir={tmp_path / 'run'}")
    assert run.wait(timeout=300) == 0, run.stderr.read()
    assert load_strokes(tmp_path / "run" / "strokes.json").background == "#a0522d"
    assert Image.open(tmp_path / "run" / "final.png").size == (64, 43)


def test_the_sweep_flag_may_stand_anywhere_in_the_command_line(tmp_path):
    run = command("nsp.paint", *TINY_PAINT, "-m", "seed=0,1", "background=#a0522d", f"hydra.sweep.dir={tmp_path}")
    assert run.wait(timeout=300) == 0, run.stderr.read()
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_dir()) == ["0_astronaut_oilpaint", "1_astronaut_oilpaint"]  # each job: its image and brush
