"""What the commands share around their work: how a bad input ends a run, and how a sweep outlives
one bad job.

A single run that cannot start exits with one line, ``error: …``, and :data:`BAD_INPUT`. In a
multirun (``-m``) the same job instead records why it failed in its own dir (``metrics.json`` with
``"status": "failed"`` and the one-line ``"error"``; a crash's traceback in ``traceback.txt``) and
returns, so the launcher goes on with the next job; :class:`FailedJobs` then ends the sweep with one
line naming the failed jobs and :data:`FAILED`. ``python -m nsp.report`` lists them as failed rows.
"""
from __future__ import annotations

import json
import sys
import traceback
from pathlib import Path
from typing import Any, Callable

from hydra.core.hydra_config import HydraConfig
from hydra.experimental.callback import Callback
from hydra.types import RunMode
from omegaconf import DictConfig

FAILED = 1  # some work failed (a crash, or jobs of a sweep)
BAD_INPUT = 2  # nothing started: a value was wrong
INTERRUPTED = 130  # Ctrl-C, as shells report SIGINT


def in_sweep() -> bool:
    return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN


def record_failure(out: Path, error: str) -> None:
    """Write the failed job's ``metrics.json``: its status and the one-line reason."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "metrics.json").write_text(json.dumps({"status": "failed", "error": error}, indent=2) + "\n")


def run_job(cfg: DictConfig, work: Callable[[DictConfig], dict], bad_input: tuple[type[Exception], ...] = (ValueError,)) -> dict | None:
    """``work(cfg)``'s metrics; on an error, one line and an exit in a single run, a failure record
    in the job's dir in a sweep (returns None).

    ``bad_input``: the exceptions whose message is the whole story (a wrong value); any other error
    in a sweep also becomes a record, with its traceback in ``traceback.txt``.
    """
    out = Path(cfg.output_dir)
    try:
        return work(cfg)
    except bad_input as error:
        if not in_sweep():
            print(f"error: {error}", file=sys.stderr)
            sys.exit(BAD_INPUT)
        record_failure(out, str(error))
        print(f"error: {out.name}: {error}", file=sys.stderr)
    except Exception as error:
        if not in_sweep():
            raise
        record_failure(out, f"{type(error).__name__}: {str(error).strip().splitlines()[0] if str(error).strip() else ''}")
        (out / "traceback.txt").write_text(traceback.format_exc())
        print(f"error: {out.name}: {type(error).__name__} (traceback in {out / 'traceback.txt'})", file=sys.stderr)
    return None


class FailedJobs(Callback):
    """Ends a multirun whose jobs recorded failures with one line and exit status :data:`FAILED`."""

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        sweep = Path(config.hydra.sweep.dir)
        jobs = [p for p in sorted(sweep.iterdir()) if (p / ".hydra").is_dir()] if sweep.is_dir() else []
        failed = [p.name for p in jobs if _status(p / "metrics.json") == "failed"]
        if failed:
            print(f"{len(failed)} of {len(jobs)} jobs failed ({', '.join(failed)}); the others finished. "
                  f"Why, per job: python -m nsp.report {sweep}", file=sys.stderr)
            sys.exit(FAILED)


def _status(path: Path) -> str | None:
    try:
        return json.loads(path.read_text()).get("status")
    except (OSError, ValueError, AttributeError):
        return None
