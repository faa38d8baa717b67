"""Reads the jobs of a Hydra multirun: overrides, final metrics, status and TensorBoard curves."""
from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper  # the job order Hydra's sweepers plan
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.errors import HydraException
from omegaconf import OmegaConf
from omegaconf.errors import OmegaConfBaseException
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from nsp.errors import BadInput

FAILED = "failed"
NOT_RUN = "not run"


@dataclass
class Job:
    """One job of a multirun.

    Attributes:
        num: Hydra's job number; for a single run's dir (no number), the dir's name.
        path: the job's output dir.
        overrides: key -> value, from ``.hydra/overrides.yaml`` (``+``/``++`` prefixes dropped).
        metrics: the job's ``metrics.json``; empty when it wrote none.
        status: ``metrics["status"]`` if given, ``completed`` if not; ``failed`` without ``metrics.json``.
        curves: TensorBoard scalar tag -> [(step, value)], by step, the last value of a repeated step.
        error: why the job failed, where known (``metrics["error"]``, or an unreadable ``metrics.json``).
    """

    num: int | str
    path: Path
    overrides: dict[str, str]
    metrics: dict = field(default_factory=dict)
    status: str = FAILED
    curves: dict[str, list[tuple[int, float]]] = field(default_factory=dict)
    error: str | None = None

    def choice(self, key: str):
        """The value of ``key`` this job ran with: its override, else what its metrics record."""
        return self.overrides.get(key, self.metrics.get(key))


def is_job(path: Path) -> bool:
    return (path / ".hydra" / "overrides.yaml").is_file()


def read_job(path: Path) -> Job:
    """The job in ``path`` (a dir with ``.hydra/overrides.yaml``)."""
    lines = OmegaConf.load(path / ".hydra" / "overrides.yaml")
    # Hydra writes every override as one "key=value" line, sweeps already expanded.
    overrides = dict(line.lstrip("+").split("=", 1) for line in lines if "=" in line)
    num = OmegaConf.select(OmegaConf.load(path / ".hydra" / "hydra.yaml"), "hydra.job.num", default=None)
    job = Job(num=path.name if num is None else int(num), path=path, overrides=overrides, curves=read_curves(path))
    metrics_file = path / "metrics.json"
    if metrics_file.is_file():
        try:
            metrics = json.loads(metrics_file.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            metrics = None
        if not isinstance(metrics, dict):
            job.error = f"{path.name}/metrics.json is not valid JSON (a job killed while writing it?)"
            return job
        job.metrics, job.status, job.error = metrics, metrics.get("status", "completed"), metrics.get("error")
    return job


def read_curves(path: Path) -> dict[str, list[tuple[int, float]]]:
    """Every scalar tag of the TensorBoard event files under ``path``, merged over event dirs."""
    curves: dict[str, dict[int, float]] = {}
    logging.getLogger("tensorboard").setLevel(logging.WARNING)  # its reader's INFO lines are not the report's
    for events in sorted({f.parent for f in path.rglob("events.out.tfevents.*")}):
        accumulator = EventAccumulator(str(events), size_guidance={"scalars": 0}).Reload()  # 0: keep all points
        for tag in accumulator.Tags()["scalars"]:
            for event in accumulator.Scalars(tag):
                curves.setdefault(tag, {})[event.step] = event.value
    return {tag: sorted(points.items()) for tag, points in curves.items()}


def collect(sweep: Path) -> list[Job]:
    """The jobs in ``sweep``: a multirun's jobs by job number (other run dirs after them, by name), or
    the one run when ``sweep`` is itself a run's dir.

    Raises ``ValueError`` naming ``sweep`` when it holds no job.
    """
    if not sweep.is_dir():
        raise BadInput(f"{sweep} is not a directory; expected a Hydra multirun dir (job dirs with .hydra/overrides.yaml)")
    if is_job(sweep):
        return [read_job(sweep)]
    jobs = [read_job(p) for p in sweep.iterdir() if p.is_dir() and is_job(p)]
    if not jobs:
        raise BadInput(f"{sweep} holds no Hydra job; expected a run dir or job dirs with .hydra/overrides.yaml (a `-m` run's sweep dir)")
    ran = {job.num for job in jobs}
    missing = [Job(num, sweep / str(num), dict(o.split("=", 1) for o in overrides), status=NOT_RUN,
                   error="the sweep ended before this job began")
               for num, overrides in enumerate(planned_jobs(sweep)) if num not in ran]
    return sorted(jobs + missing, key=lambda job: (isinstance(job.num, str), job.num if isinstance(job.num, int) else 0, str(job.num)))


def planned_jobs(sweep: Path) -> list[list[str]]:
    """Each job's overrides (``key=value``), by job number, as the multirun planned them in its
    ``multirun.yaml``, so jobs of an aborted sweep that never began are listed too; [] if unknown."""
    try:
        config = OmegaConf.load(sweep / "multirun.yaml")
        params = [f"{key}={value}" for key, value in (config.hydra.sweeper.get("params") or {}).items()]
        overrides = OverridesParser.create().parse_overrides(params + list(config.hydra.overrides.task))
        return [job for batch in BasicSweeper.split_arguments(overrides, None) for job in batch]
    except (OSError, OmegaConfBaseException, HydraException):
        return []


def latest_sweep(root: Path) -> Path:
    """The most recently started multirun under ``root`` (``root/<name>/<sweep>/`` holding job dirs).

    Raises ``ValueError`` naming ``root`` when it holds none.
    """
    sweeps = [p for p in root.glob("*/*") if p.is_dir() and any(is_job(job) for job in p.iterdir() if job.is_dir())]
    if not sweeps:
        raise BadInput(f"{root} holds no multirun; give the sweep dir: python -m nsp.report multirun/<name>/<time>")
    return max(sweeps, key=lambda p: (p / "multirun.yaml").stat().st_mtime if (p / "multirun.yaml").is_file() else p.stat().st_mtime)


def swept_keys(jobs: list[Job]) -> list[str]:
    """Override keys whose value differs between jobs, in the order the first jobs list them."""
    keys = list(dict.fromkeys(key for job in jobs for key in job.overrides))
    return [key for key in keys if len({job.overrides.get(key) for job in jobs}) > 1]


def common_overrides(jobs: list[Job]) -> dict[str, str]:
    """Overrides every job shares (the experiment, shortened budgets, …)."""
    swept = set(swept_keys(jobs))
    return {key: value for key, value in jobs[0].overrides.items() if key not in swept}
