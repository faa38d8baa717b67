"""Runs on other machines' paths, tried on this one: Lightning's DDP started from the command line,
and sweeps through submitit (Slurm's launcher) with its local executor, each job a process of its own."""
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nsp.files import running
from test_runs import foreground
from test_sweeps import TINY_PAINT, TINY_TRAIN

DDP = ["trainer=ddp", "trainer.accelerator=cpu", "trainer.devices=2", "trainer.max_steps=4", "data.epoch_size=256",
       "data.num_workers=0"]  # the command line of docs/training.md, as a user types it
SMALL = ["renderer=dcgan", "model.channel_mult=0.125", "data.batch_size=8", "data.val_size=16", "data.test_size=16",
         "trainer.num_sanity_val_steps=0", "trainer.enable_progress_bar=false"]  # the same work, kept small


def metrics(job: Path) -> dict:
    return json.loads((job / "metrics.json").read_text())


@pytest.mark.parametrize("where", ["named", "default"])
def test_ddp_from_the_command_line_trains_two_processes_into_one_run_dir(where, tmp_path):
    """Lightning starts rank 1 by running the command again into rank 0's ``hydra.run.dir``: it joins
    that dir (rank 0's claim) and writes no run's files of its own."""
    named = [f"hydra.run.dir={tmp_path / 'run'}"] if where == "named" else []
    done = subprocess.run([sys.executable, "-m", "nsp.train", *DDP, *SMALL, *named], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "error" not in done.stderr
    (run,) = [tmp_path / "run"] if named else list((tmp_path / "outputs" / "train").iterdir())
    assert [p.parent for p in tmp_path.rglob("metrics.json")] == [run]
    assert (metrics(run)["status"], metrics(run)["steps"]) == ("completed", 4)
    assert (run / "checkpoints" / "last.ckpt").is_file() and len(list(run.glob("events.out.tfevents.*"))) == 1
    assert (run / "train_ddp_process_1.log").is_file()  # rank 1's log, Lightning's name for it
    lines = done.stdout.splitlines()  # rank 1 says nothing rank 0 does not
    assert sum(line.startswith("training renderer dcgan") for line in lines) == sum(line.startswith("trained dcgan") for line in lines) == 1


def test_slurm_tasks_each_running_the_command_train_one_run_into_one_dir(tmp_path):
    """What ``srun`` does for two one-GPU nodes, on this machine: it starts the command once per task,
    each with its rank in Slurm's variables (Lightning's ``SLURMEnvironment`` reads them). Task 0 claims
    the named dir; task 1 joins it, where it once was refused (and task 0 waited for it until torch timed out)."""
    with socket.socket() as free:
        free.bind(("127.0.0.1", 0))
        port = free.getsockname()[1]
    line = [sys.executable, "-m", "nsp.train", "trainer=ddp", "trainer.accelerator=cpu", "trainer.devices=1", "trainer.num_nodes=2",
            *DDP[3:], *SMALL, f"hydra.run.dir={tmp_path / 'run'}"]
    slurm = {"SLURM_NTASKS": "2", "SLURM_NNODES": "2", "SLURM_NTASKS_PER_NODE": "1", "SLURM_LOCALID": "0", "SLURM_JOB_NAME": "nsp",
             "SLURM_JOB_ID": "4242", "SLURM_NODELIST": "localhost", "MASTER_ADDR": "127.0.0.1", "MASTER_PORT": str(port)}
    tasks = [subprocess.Popen(line, env=os.environ | slurm | {"SLURM_PROCID": str(r), "SLURM_NODEID": str(r)}, cwd=tmp_path,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for r in (0, 1)]
    outputs = [task.communicate(timeout=300) for task in tasks]
    assert [task.returncode for task in tasks] == [0, 0], [err[-1000:] for _, err in outputs]
    assert [p.parent for p in tmp_path.rglob("metrics.json")] == [tmp_path / "run"]
    assert (metrics(tmp_path / "run")["status"], metrics(tmp_path / "run")["steps"]) == ("completed", 4)
    assert [sum(line.startswith("trained dcgan") for line in out.splitlines()) for out, _ in outputs] == [1, 0]


def test_submitit_local_runs_a_painting_sweep_each_job_a_process_on_a_core(tmp_path):
    done = subprocess.run([sys.executable, "-m", "nsp.paint", "-m", "seed=0,1", *TINY_PAINT, "hydra/launcher=submitit_local",
                           f"hydra.sweep.dir={tmp_path}"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.splitlines()[0] == ("the jobs run side by side, each a process of its own (submitit's); "
                                           f"their output: {tmp_path}/.submitit/<job id>")
    jobs = [tmp_path / f"{n}_astronaut_oilpaint" for n in (0, 1)]
    assert [(metrics(job)["strokes"], metrics(job)["threads"]) for job in jobs] == [(8, 1), (8, 1)]
    assert all((job / "final.png").is_file() for job in jobs)


def test_sigterm_stops_a_submitit_local_training_sweep_whose_workers_keep_their_checkpoints_and_it_resumes(tmp_path):
    """SIGTERM to the command (its process alone, as ``timeout`` sends it) reaches each job's process,
    which stops between steps and saves ``last.ckpt``; the command waits for them, so none outlives it.
    The same command again resumes both jobs from their checkpoints."""
    sweep = [sys.executable, "-m", "nsp.train", "-m", "renderer=dcgan", "brush=tape", "seed=0,1", "data.epoch_size=40",
             "trainer.max_steps=60", *(o for o in TINY_TRAIN if not o.startswith(("trainer.max_steps", "data.epoch_size"))),
             "hydra/launcher=submitit_local", f"hydra.sweep.dir={tmp_path}"]
    jobs = [tmp_path / f"{n}_dcgan_tape" for n in (0, 1)]
    run = subprocess.Popen(sweep, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, preexec_fn=foreground)
    deadline = time.monotonic() + 240
    while not (jobs[0] / "checkpoints" / "last.ckpt").exists():  # job 0 is past its first epoch; job 1 started or about to
        assert run.poll() is None and time.monotonic() < deadline, run.communicate()[1]
        time.sleep(0.1)
    run.send_signal(signal.SIGTERM)
    assert run.wait(timeout=120) == 130
    assert run.stderr.read().strip().splitlines()[-1] == (
        f"interrupted: each of the 2 jobs kept what it had; per job: python -m nsp.report {tmp_path}")
    statuses = [metrics(job)["status"] for job in jobs]  # job 1, a process of its own, may be done first on a busy machine
    assert statuses[0] == "interrupted" and statuses[1] in ("interrupted", "completed")
    assert 0 < metrics(jobs[0])["steps"] < 60 and (jobs[0] / "checkpoints" / "last.ckpt").is_file()
    workers = [int(p.name) for p in (tmp_path / ".submitit").iterdir() if p.name.isdigit()]  # submitit's: named by pid
    workers += [int(p.name.split(".")[-2]) for job in jobs for p in job.glob("events.out.tfevents.*")]  # the jobs'
    assert len(workers) >= 2 and not any(running(pid) for pid in workers)

    again = subprocess.run(sweep, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr[-2000:]
    kept = "1 completed job" if statuses[1] == "completed" else "0 completed jobs"
    assert f"resuming the sweep in {tmp_path}: {kept} kept, the rest run, training from its last.ckpt" in again.stdout
    assert [(metrics(job)["status"], metrics(job)["steps"]) for job in jobs] == [("completed", 60)] * 2
