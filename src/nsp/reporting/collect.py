"""Reads the jobs of a Hydra multirun: overrides, final metrics, status and TensorBoard curves."""
from __future__ import annotations

import itertools
import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.errors import HydraException
from omegaconf import OmegaConf
from omegaconf.errors import OmegaConfBaseException
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
import yaml

from nsp.errors import BadInput

FAILED = "failed"
NOT_RUN = "not run"
YAML_ERRORS = (OSError, ValueError, yaml.YAMLError, OmegaConfBaseException)


@dataclass
class Job:
    """One job of a multirun."""

    num: int | str  # Hydra's job number; for a single run's dir (no number), the dir's name
    path: Path  # the job's output dir
    overrides: dict[str, str]  # key -> value, from .hydra/overrides.yaml (+/++ prefixes dropped)
    metrics: dict = field(default_factory=dict)  # its metrics.json; empty when it wrote none
    status: str = FAILED  # metrics["status"] if given, else completed; failed without metrics.json
    curves: dict[str, list[tuple[int, float]]] = field(default_factory=dict)  # TensorBoard tag -> [(step, value)]
    error: str | None = None  # why the job failed, where known (metrics["error"], an unreadable metrics.json)

    def choice(self, key: str):
        """Its override of ``key``, else its metric ``key`` or its last part (``lr`` of ``model.optimizer.lr``)."""
        return self.overrides.get(key, self.metrics.get(key, self.metrics.get(key.rsplit(".", 1)[-1])))


def is_job(path: Path) -> bool:
    return (path / ".hydra" / "overrides.yaml").is_file()


def read_job(path: Path) -> Job:
    """The job in ``path``; what cannot be read (overrides not ``key=value`` lines, a ``metrics.json`` not a
    JSON object, metric values neither text nor a number a float holds) is left out and said in ``error``."""
    overrides = read_overrides(path / ".hydra" / "overrides.yaml")
    job = Job(num=job_number(path), path=path, overrides=overrides or {}, curves=read_curves(path))
    if overrides is None:
        job.error = f"{path.name}/.hydra/overrides.yaml is not a list of key=value lines; its choices are not shown"
    metrics_file = path / "metrics.json"
    if metrics_file.is_file():
        try:
            metrics = json.loads(metrics_file.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError, RecursionError, ValueError, OSError):
            metrics = None
        if not isinstance(metrics, dict):
            job.error = f"{path.name}/metrics.json is not valid JSON (a job killed while writing it?)"
            return job
        # what the report can show: text, a bool, or a number a float holds
        job.metrics = {key: value for key, value in metrics.items() if isinstance(value, (str, bool, float))
                       or (isinstance(value, int) and abs(value) < 2 ** 1023)}
        status, error = job.metrics.get("status", "completed"), job.metrics.get("error")
        job.status = status if isinstance(status, str) else FAILED
        job.error = error if isinstance(error, str) else job.error
        if len(job.metrics) < len(metrics):
            unread = ", ".join(sorted(set(metrics) - set(job.metrics)))
            job.error = job.error or f"{path.name}/metrics.json: {unread} is neither text nor a number; left out"
    return job


def read_overrides(path: Path) -> dict[str, str] | None:
    """``key -> value`` of Hydra's ``overrides.yaml`` (sweeps expanded, ``+``/``++`` dropped); None
    when it is not a list of ``key=value`` lines."""
    try:
        lines = OmegaConf.to_container(OmegaConf.load(path))
    except YAML_ERRORS:
        return None
    if not isinstance(lines, list) or not all(isinstance(line, str) and "=" in line for line in lines):
        return None
    return dict(line.lstrip("+").split("=", 1) for line in lines)


def job_number(path: Path) -> int | str:
    """Hydra's job number from ``.hydra/hydra.yaml``; the dir's name where it holds none (a single run)."""
    try:
        num = OmegaConf.select(OmegaConf.load(path / ".hydra" / "hydra.yaml"), "hydra.job.num", default=None)
    except YAML_ERRORS:
        return path.name
    return num if isinstance(num, int) and not isinstance(num, bool) else path.name


def read_curves(path: Path) -> dict[str, list[tuple[int, float]]]:
    """Every scalar tag of the TensorBoard event files under ``path``, merged over the files (a later
    file's point at a step replaces an earlier one's: a resumed run)."""
    curves: dict[str, dict[int, float]] = {}
    logging.getLogger("tensorboard").setLevel(logging.WARNING)  # its reader's INFO lines are not the report's
    for events in sorted(f for f in path.rglob("events.out.tfevents.*") if f.is_file()):  # by name: by time
        accumulator = EventAccumulator(str(events), size_guidance={"scalars": 0}).Reload()  # 0: keep all points
        for tag in accumulator.Tags()["scalars"]:
            for event in accumulator.Scalars(tag):
                curves.setdefault(tag, {})[event.step] = event.value
    return {tag: sorted(points.items()) for tag, points in curves.items()}


def collect(sweep: Path) -> list[Job]:
    """The jobs in ``sweep`` by job number (other run dirs after them, by name), those planned but
    never begun included; or the one run when ``sweep`` is a run's dir. Raises BadInput when it holds none."""
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
    """Each job's overrides (``key=value``) by job number, as ``multirun.yaml`` planned them; [] if
    unknown. In the basic sweeper's order: every combination, the last key varying fastest, a key of
    the command line replacing the sweeper's ``params`` entry it overrides."""
    try:
        config = OmegaConf.load(sweep / "multirun.yaml")
        params = [f"{key}={value}" for key, value in (config.hydra.sweeper.get("params") or {}).items()]
        values = {}
        for override in OverridesParser.create().parse_overrides(params + list(config.hydra.overrides.task)):
            key = override.get_key_element()
            swept = override.sweep_string_iterator() if override.is_sweep_override() else [override.get_value_element_as_str()]
            values[key] = [f"{key}={value}" for value in swept]
    except (OSError, OmegaConfBaseException, HydraException):
        return []
    return [list(job) for job in itertools.product(*values.values())]


def latest_sweep(root: Path) -> Path:
    """The most recently started multirun under ``root`` (``root/<name>/<sweep>/`` holding job dirs)."""
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
