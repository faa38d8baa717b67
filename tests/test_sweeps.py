"""A sweep outlives a bad job: the job records why it failed, the others run, the sweep ends naming it."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nsp.io.strokes import load_strokes
from test_runs import foreground
from nsp.reporting import write_report

TINY_TRAIN = ["model.channel_mult=0.125", "trainer.max_steps=2", "data.batch_size=8", "data.epoch_size=16", "data.val_size=16",
              "data.test_size=16", "data.num_workers=0", "trainer.enable_progress_bar=false"]
TINY_PAINT = ["strokes=8", "work_size=64", "render_size=64", "animation_size=64", "progress=false"]


def sweep(command: str, sweep_dir: Path, *overrides: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", command, "-m", *overrides, f"hydra.sweep.dir={sweep_dir}"],
                          capture_output=True, text=True, timeout=300)


def metrics(job: Path) -> dict:
    return json.loads((job / "metrics.json").read_text())


def test_a_training_sweep_runs_every_job_past_a_bad_value(tmp_path):
    done = sweep("nsp.train", tmp_path, "model.size=48,32", *TINY_TRAIN)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1].startswith("1 of 2 jobs failed (0_dual_watercolor); the others finished.")
    assert "Traceback" not in done.stderr
    assert metrics(tmp_path / "0_dual_watercolor") == {"status": "failed", "error": "renderer size must be one of 32, 64, 128, got 48"}
    assert metrics(tmp_path / "1_dual_watercolor")["status"] == "completed"
    report = write_report(tmp_path)[0].read_text()
    assert "2 jobs: 1 completed, 1 failed." in report and "- job 0: renderer size must be one of 32, 64, 128, got 48" in report


def test_a_parallel_painting_sweep_keeps_the_good_paintings_past_a_missing_image(tmp_path):
    done = sweep("nsp.paint", tmp_path, "image=chelsea,/nonexistent/photo.png", *TINY_PAINT, "hydra/launcher=joblib")
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "error: 1_photo_oilpaint: image=/nonexistent/photo.png: no such file" in done.stderr
    assert metrics(tmp_path / "0_chelsea_oilpaint")["strokes"] == 8 and (tmp_path / "0_chelsea_oilpaint" / "final.png").is_file()
    failed = metrics(tmp_path / "1_photo_oilpaint")
    assert failed["status"] == "failed" and "no such file" in failed["error"]


@pytest.mark.parametrize(("sig", "whom"), [(signal.SIGINT, "group"), (signal.SIGTERM, "parent")])
def test_an_interrupted_parallel_sweep_keeps_each_jobs_painting_and_starts_no_other(sig, whom, tmp_path):
    """Ctrl-C reaches every process of the terminal's group; SIGTERM (``timeout``, Slurm) the parent only."""
    run = subprocess.Popen([sys.executable, "-m", "nsp.paint", "-m", "image=astronaut,chelsea,coffee", "strokes=20000",
                            "work_size=128", "progress=false", "hydra/launcher=joblib", "hydra.launcher.n_jobs=2",
                            f"hydra.sweep.dir={tmp_path}"],
                           start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=foreground)
    deadline = time.monotonic() + 180
    while not all(any((tmp_path / job).glob("events.out.tfevents.*")) for job in ("0_astronaut_oilpaint", "1_chelsea_oilpaint")):
        assert run.poll() is None and time.monotonic() < deadline, run.communicate()[1]
        time.sleep(0.5)
    time.sleep(10)  # each job past its first strokes, even with the whole suite running beside it
    os.killpg(run.pid, sig) if whom == "group" else run.send_signal(sig)
    _, stderr = run.communicate(timeout=180)
    assert run.returncode == 130 and "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1] == f"interrupted: each of the 3 jobs kept what it had; per job: python -m nsp.report {tmp_path}"
    for job in ("0_astronaut_oilpaint", "1_chelsea_oilpaint"):
        assert metrics(tmp_path / job)["status"] == "interrupted"
        assert 0 < len(load_strokes(tmp_path / job / "strokes.json").strokes) < 20000
        assert (tmp_path / job / "final.png").is_file()
    assert metrics(tmp_path / "2_coffee_oilpaint") == {"status": "interrupted", "error": "the sweep was interrupted before this job began"}
    assert not (tmp_path / "2_coffee_oilpaint" / "strokes.json").exists()


def test_a_stopped_training_sweep_run_again_resumes_and_matches_a_sweep_never_stopped(tmp_path):
    """SIGTERM mid-way through job 1 of 3; the same command again keeps job 0 untouched, resumes job 1
    from its last.ckpt, runs job 2, and every job ends as in a sweep that was never stopped."""
    steps = ["renderer=dcgan", "brush=tape", "data.epoch_size=80", "trainer.max_steps=40", "seed=0,1,2",
             *(o for o in TINY_TRAIN if not o.startswith(("trainer.max_steps", "data.epoch_size")))]
    stopped, never = tmp_path / "stopped", tmp_path / "never"
    run = subprocess.Popen([sys.executable, "-m", "nsp.train", "-m", *steps, f"hydra.sweep.dir={stopped}"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, preexec_fn=foreground)
    deadline = time.monotonic() + 240
    while not (stopped / "1_dcgan_tape" / "checkpoints" / "last.ckpt").exists():  # job 1 is past its first epoch
        assert run.poll() is None and time.monotonic() < deadline, run.communicate()[1]
        time.sleep(0.1)
    run.send_signal(signal.SIGTERM)
    assert run.wait(timeout=120) == 130
    assert [metrics(stopped / f"{n}_dcgan_tape")["status"] for n in range(3)] == ["completed", "interrupted", "interrupted"]
    assert metrics(stopped / "1_dcgan_tape")["steps"] < 40
    finished = (stopped / "0_dcgan_tape" / "checkpoints" / "last.ckpt").stat().st_mtime_ns

    other = sweep("nsp.train", stopped, "renderer=dcgan", "brush=tape", "seed=7,8")  # another command: still refused
    assert other.returncode == 2 and "already holds another sweep" in other.stderr.strip().splitlines()[-1]
    again = sweep("nsp.train", stopped, *steps)
    assert again.returncode == 0, again.stderr
    assert f"resuming the sweep in {stopped}: 1 completed job kept, the rest run, training from its last.ckpt" in again.stdout
    assert "0_dcgan_tape: completed in an earlier run of this sweep; kept" in again.stdout
    assert again.stdout.count("training renderer dcgan") == again.stdout.count("trained dcgan") == 2  # not the kept job
    assert (stopped / "0_dcgan_tape" / "checkpoints" / "last.ckpt").stat().st_mtime_ns == finished
    assert sweep("nsp.train", never, *steps).returncode == 0
    for n in range(3):
        resumed, straight = (metrics(root / f"{n}_dcgan_tape") for root in (stopped, never))
        assert {**resumed, "seconds": 0} == {**straight, "seconds": 0}, n
    assert "3 jobs: 3 completed." in write_report(stopped)[0].read_text()


def test_one_painting_takes_every_core_and_a_parallel_sweeps_jobs_one_each(tmp_path):
    env = os.environ | {"OMP_NUM_THREADS": "2"}  # torch's default on a 2-core machine, whatever this one has
    paint = [sys.executable, "-m", "nsp.paint", *TINY_PAINT]
    subprocess.run([*paint, f"hydra.run.dir={tmp_path / 'one'}"], env=env, check=True, capture_output=True, timeout=300)
    assert metrics(tmp_path / "one")["threads"] == 2
    for launcher, threads in (("joblib", 1), ("basic", 2)):  # side by side: a core each; one at a time: all of them
        subprocess.run([*paint, "-m", "seed=0,1", f"hydra/launcher={launcher}", f"hydra.sweep.dir={tmp_path / launcher}"],
                       env=env, check=True, capture_output=True, timeout=300)
        assert [metrics(job)["threads"] for job in sorted((tmp_path / launcher).glob("*_astronaut_oilpaint"))] == [threads] * 2


@pytest.mark.parametrize("command", ["paint", "train", "render"])
def test_no_config_of_nsp_sets_hydra_mode(command):  # the command line alone decides it (nsp.cli._mode_from_the_line)
    import importlib

    from hydra import compose, initialize_config_dir

    from nsp.config import CONF

    importlib.import_module(f"nsp.{command}").schema()  # registers the command's structured config
    experiments = sorted(path.stem for path in (CONF / command / "experiment").glob("*.yaml"))
    with initialize_config_dir(str(CONF / command), version_base="1.3"):
        for overrides in [[], *([f"experiment={name}"] for name in experiments)]:
            assert compose(command, overrides=overrides, return_hydra_config=True).hydra.mode is None, overrides


def test_hydra_mode_on_the_command_line_still_makes_a_sweep(tmp_path):
    done = subprocess.run([sys.executable, "-m", "nsp.paint", "hydra.mode=MULTIRUN", "seed=0,1", *TINY_PAINT,
                           f"hydra.sweep.dir={tmp_path}"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert sorted(metrics(job)["strokes"] for job in tmp_path.iterdir() if job.is_dir()) == [8, 8]


def test_a_sweep_resumes_with_its_overrides_in_another_order_but_not_its_swept_keys(tmp_path):
    """Hydra numbers a sweep's jobs (and so names their dirs) in the order of its swept keys; the other
    overrides may come in any order."""
    assert sweep("nsp.paint", tmp_path, "seed=0,1", "strokes=4,8", *TINY_PAINT[1:]).returncode == 0
    again = sweep("nsp.paint", tmp_path, *reversed(TINY_PAINT[1:]), "seed=0,1", "strokes=4,8")
    assert again.returncode == 0, again.stderr
    assert f"resuming the sweep in {tmp_path}: 4 completed jobs kept, the rest run" in again.stdout
    swapped = sweep("nsp.paint", tmp_path, "strokes=4,8", "seed=0,1", *TINY_PAINT[1:])
    assert swapped.returncode == 2
    assert swapped.stderr.strip() == (f"error: hydra.sweep.dir={tmp_path} holds this sweep with its swept keys in another "
                                      "order (seed, strokes), which numbers its jobs otherwise; give them in that order to resume it")
    assert [metrics(tmp_path / f"{n}_astronaut_oilpaint")["strokes"] for n in range(4)] == [4, 8, 4, 8]


def test_a_resumed_training_job_whose_last_checkpoint_is_corrupt_says_so_in_one_line(tmp_path):
    steps = ["renderer=dcgan", "brush=tape", "seed=0", *TINY_TRAIN]
    assert sweep("nsp.train", tmp_path, *steps).returncode == 0
    job = tmp_path / "0_dcgan_tape"
    (job / "metrics.json").write_text(json.dumps({"status": "interrupted"}))  # as a stopped job leaves it: it resumes
    last = job / "checkpoints" / "last.ckpt"
    damaged = bytearray(last.read_bytes())
    damaged[len(damaged) // 2] ^= 0xFF  # one byte of its weights, as a failing disk or a bad copy leaves it
    last.write_bytes(damaged)
    again = sweep("nsp.train", tmp_path, *steps)
    assert again.returncode == 1 and "Traceback" not in again.stderr and "diverged" not in again.stderr
    error = metrics(job)["error"]
    assert error.startswith(f"ckpt_path={last} is corrupt: its part archive/data/") and "\n" not in error
    assert error.endswith("is not as it was saved (a checksum differs); resume from another checkpoint, or remove it to train from the start")
    assert f"error: 0_dcgan_tape: {error}" in again.stderr.splitlines()
