"""What the commands add to Hydra and Lightning: one-line errors and exit codes, a dir per run,
sweeps that outlive a bad job and resume, and Ctrl-C and SIGTERM that keep what a run had.

Hydra composes, checks and sweeps each command's config and prints its ``--help``; :func:`command`
turns its several-line errors into one line. A single run that cannot start exits with one line,
``error: …``, and :data:`BAD_INPUT`. In a multirun (``-m``) the job instead records why it failed in
its own dir (``metrics.json`` with ``"status": "failed"`` and the ``"error"``; a crash's traceback in
``traceback.txt``) so the launcher goes on; :class:`Sweeps` then ends the sweep with one line naming
the failed jobs and :data:`FAILED`. Ctrl-C and SIGTERM (``timeout``, Slurm, ``docker stop``) both
interrupt: the work keeps what it had, and the command exits with :data:`INTERRUPTED`.

This module imports only Hydra at the top, so ``--help`` and a command's first line come before torch loads.
"""
from __future__ import annotations

import difflib
import errno
import gc
import json
import logging
import os
import re
import shutil
import signal
import sys
import threading
import traceback
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, NoReturn

import hydra
from hydra.core.global_hydra import GlobalHydra
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.errors import HydraException, InstantiationException, MissingConfigException, OverrideParseException
from hydra.experimental.callback import Callback
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf, read_write
from omegaconf.errors import OmegaConfBaseException
import yaml

from nsp.config import CONF, job_metrics
from nsp.errors import BadInput, RunFailed
from nsp.signals import interrupt
from nsp.text import counted


FAILED = 1  # some work failed (a crash, or jobs of a sweep)
BAD_INPUT = 2  # nothing started: a value was wrong
INTERRUPTED = 130  # Ctrl-C or SIGTERM; shells report SIGINT as 130

CLAIM = ".nsp-run"  # in a dir named by hydra.run.dir: locked by the run that took it (_take), its process id
STOPPED = ".interrupted"  # in a sweep's dir: Ctrl-C or SIGTERM reached the sweep; no further job starts
# What a disk may refuse a write with: full, over quota, read-only, not ours, failing, file too large.
REFUSED_WRITES = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EIO, errno.EFBIG}
# What an error says when the machine's memory or its limit on processes and threads ran out.
LIMITS = ("can't allocate memory", "cannot allocate memory", "failed to map segment", "out of memory",
          "can't start new thread", "resource temporarily unavailable")
RANKS = ("RANK", "LOCAL_RANK", "NODE_RANK", "SLURM_PROCID")  # torchrun's, Lightning's, Slurm's (each task)
JOBLIB = "hydra_plugins.hydra_joblib_launcher._core"  # the logger of the joblib launcher plugin

_sweep_process: int | None = None  # the process of the sweep's command, once it has started its workers' launcher
_working = False  # a job's work runs in this process
_CLAIMS: list[int] = []  # the claim files this process holds locked, open for the rest of its life


def in_sweep() -> bool:
    return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN


def record(out: Path, status: str, error: str) -> None:
    """Write the job's ``metrics.json`` where the work did not: its status and the one-line reason.
    Where the disk refuses even that, the reason goes to stderr only (the sweep goes on)."""
    from nsp.files import write_json

    try:
        out.mkdir(parents=True, exist_ok=True)
        if status == "failed" or not (out / "metrics.json").is_file():
            write_json(out / "metrics.json", {"status": status, "error": error})
    except OSError as refused:
        print(f"error: {out.name}: could not record its status ({refused.strerror or refused}): {error}", file=sys.stderr)


def refused_write(error: OSError, out: Path) -> str:
    """One line for a write the disk refused: why, where, and which files the run's dir kept."""
    return (f"{error.strerror or error} while writing into {out}; the run stopped, keeping {_kept(out)} "
            "(each whole: files are written beside their place, then renamed)")


def _kept(out: Path) -> str:
    """The files in a run's dir ``out``, for a line: ``strokes.json, paint.log`` or ``no file``."""
    kept = sorted(p.name for p in out.iterdir() if p.is_file() and not p.name.startswith(".")) if out.is_dir() else []
    return ", ".join(kept) or "no file"


def kept(cfg: DictConfig) -> bool:
    """Whether this job is one of a sweep run again that an earlier run completed: :func:`run_job`
    keeps its metrics instead of running it (so a command says nothing of starting it)."""
    return in_sweep() and _status(Path(cfg.output_dir) / "metrics.json") == "completed"


def run_job(cfg: DictConfig, work: Callable[[DictConfig], Any]) -> Any:
    """``work(cfg)``'s result; on an error, one line and an exit in a single run, a record in the
    job's dir in a sweep (returns None; a crash's traceback in ``traceback.txt``). An interrupted job
    of a sweep is recorded as such, and the jobs after it do not start. A sweep run again into its
    own dir (:class:`RunDirs`) keeps the jobs that completed (their recorded metrics are the result)
    and resumes interrupted training from the job's ``last.ckpt``. A side-by-side job gets one thread.
    """
    out = Path(cfg.output_dir)
    stop = Path(HydraConfig.get().sweep.dir) / STOPPED if in_sweep() else None
    if stop is not None and stop.exists():
        record(out, "interrupted", "the sweep was interrupted before this job began")
        return None
    if kept(cfg):  # a sweep run again: its finished jobs stay
        print(f"{out.name}: completed in an earlier run of this sweep; kept", flush=True)
        return json.loads((out / "metrics.json").read_text())
    if stop is not None and cfg.get("ckpt_path", "") is None and (last := out / "checkpoints" / "last.ckpt").is_file():
        cfg.ckpt_path = str(last)  # an interrupted training job of a sweep run again: on from where it stopped
    try:
        with _heeding(stop):
            use_threads(1 if cfg.get("threads") is None and side_by_side() else cfg.get("threads"))
            return work(cfg)
    except KeyboardInterrupt:
        if stop is None:
            raise
        stop.touch()
        record(out, "interrupted", "interrupted (Ctrl-C or SIGTERM); the job kept what it had")
    except Exception as error:
        if (message := failure(error, out)) is None:  # a crash
            if stop is None:
                raise
            record(out, "failed", f"{type(error).__name__}: {str(error).strip().splitlines()[0] if str(error).strip() else ''}")
            with suppress(OSError):  # a full disk: the record's line on stderr is all there is
                (out / "traceback.txt").write_text(traceback.format_exc())
            print(f"error: {out.name}: {type(error).__name__} (traceback in {out / 'traceback.txt'})", file=sys.stderr)
            return None
        _log_to_file(out, f"error: {message}")
        if stop is None and isinstance(error, (BadInput, InstantiationException)):
            _unmade_run(out)
            fail(message)
        if stop is None:
            fail(message, FAILED)
        record(out, "failed", message)
        print(f"error: {out.name}: {message}", file=sys.stderr)
    return None


def use_threads(threads: int | None) -> None:
    """Set torch's CPU threads for this process as its work starts; None keeps torch's default
    (every core, ``OMP_NUM_THREADS`` honoured)."""
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise BadInput(f"threads={threads}: expected a positive number of threads, or null for torch's default")
    if threads is not None:
        import torch

        torch.set_num_threads(threads)


def failure(error: Exception, out: Path) -> str | None:
    """The one line for an error a run ends with, ``out`` its dir: a value refused, a run that could
    not go on, a write the disk refused, a limit of the machine reached; None for a crash (a bug)."""
    if isinstance(error, (BadInput, InstantiationException, RunFailed)):
        return _one_line(error)
    if isinstance(error, OSError) and error.errno in REFUSED_WRITES:
        return refused_write(error, out)
    if isinstance(error, MemoryError) or any(limit in str(error).lower() for limit in LIMITS):
        return (f"a limit of this machine stopped the run ({(str(error).strip() or type(error).__name__).splitlines()[0]}); "
                f"it kept {_kept(out)}. Free memory or raise the limit (ulimit -v, ulimit -u), or ask for less "
                "(strokes=, render_size=)")
    return None


def _log_to_file(out: Path, message: str) -> None:
    """``message`` as an error into the run's own log file in ``out`` alone (the console's line is :func:`fail`'s)."""
    record = logging.getLogger(__name__).makeRecord(__name__, logging.ERROR, __file__, 0, message, None, None)
    for handler in logging.getLogger().handlers:
        if isinstance(handler, logging.FileHandler) and Path(handler.baseFilename).parent == out.absolute():
            handler.handle(record)


class Sweeps(Callback):
    """How a multirun starts (a line saying how its jobs run) and ends: one line and :data:`FAILED`
    when jobs recorded failures, :data:`INTERRUPTED` after Ctrl-C or SIGTERM.

    Under the basic launcher a signal interrupts the job itself, run in this process. Under joblib
    and ``submitit_local`` this process waits for its workers instead of killing them mid-save:
    Ctrl-C reaches each from the terminal, and SIGTERM, sent to this process alone, is written into
    the sweep's :data:`STOPPED` file, which each working job takes as its Ctrl-C (:func:`_heeding`).
    Under ``submitit_local`` this process ignores Ctrl-C, so that submitit's process between it and
    each job (which would kill its job a second after a Ctrl-C) inherits that.
    """

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        global _sweep_process
        how = launcher(config.hydra)
        folder = str(config.hydra.launcher.get("submitit_folder", "")).replace("%j", "<job id>")
        said = {"basic": "the jobs run one at a time, in this process (hydra/launcher=joblib: side by side)",
                "submitit_slurm": "the jobs run as Slurm jobs, through submitit; this command waits for them "
                                  f"(their output: {folder})",
                "submitit_local": "the jobs run side by side, each a process of its own (submitit's); "
                                  f"their output: {folder}"}
        if how == "joblib":
            logging.getLogger(JOBLIB).addFilter(_how_jobs_run)  # its own line says how many side by side
        else:
            print(said.get(how, f"the jobs run as {config.hydra.launcher.get('_target_')} runs them"), flush=True)
        if how in ("basic", "submitit_slurm"):
            return  # basic: Ctrl-C and SIGTERM interrupt the job itself
        stop, _sweep_process = Path(config.hydra.sweep.dir) / STOPPED, os.getpid()

        def wait(signum: int, frame: Any) -> None:
            stop.parent.mkdir(parents=True, exist_ok=True)
            with open(stop, "a") as told:  # Ctrl-C reached the workers too; SIGTERM only this process: pass it on
                told.write("SIGTERM\n" if signum == signal.SIGTERM else "")
            if _working:  # the job runs in this process (joblib's n_jobs=1): it stops itself
                raise KeyboardInterrupt

        signal.signal(signal.SIGINT, signal.SIG_IGN if how == "submitit_local" else wait)
        signal.signal(signal.SIGTERM, wait)

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        sweep = Path(config.hydra.sweep.dir)
        jobs = [p for p in sorted(sweep.iterdir()) if (p / ".hydra").is_dir()] if sweep.is_dir() else []
        if (sweep / STOPPED).exists():
            print(f"interrupted: each of the {len(jobs)} jobs kept what it had; per job: python -m nsp.report {sweep}",
                  file=sys.stderr)
            sys.exit(INTERRUPTED)
        failed = [p.name for p in jobs if _status(p / "metrics.json") in ("failed", None)]  # None: it could not record
        if failed:
            print(f"{len(failed)} of {len(jobs)} jobs failed ({', '.join(failed)}); the others finished. "
                  f"Why, per job: python -m nsp.report {sweep}", file=sys.stderr)
            sys.exit(FAILED)


def _how_jobs_run(record: logging.LogRecord) -> bool:
    """The joblib launcher's first line (its 13 settings), said plainly: how many jobs side by side."""
    if match := re.match(r"Joblib\.Parallel\(n_jobs=(-?\d+).* is launching (\d+) jobs", record.getMessage()):
        at_once = "one process per core" if match[1] == "-1" else f"{match[1]} processes"
        record.msg, record.args = f"launching {counted(match[2], 'job')} side by side, {at_once}", ()
    return True


def launcher(hydra: DictConfig) -> str:
    """The launcher a sweep's Hydra node chose, as ``hydra/launcher=`` names it (``basic``, ``joblib``, …)."""
    return hydra.runtime.choices.get("hydra/launcher", "basic")


def side_by_side() -> bool:
    """Whether this is a job of a sweep whose jobs run side by side on this machine: joblib's
    processes (``n_jobs`` other than 1), or each job a process of its own (``submitit_local``)."""
    if not in_sweep():
        return False
    how = launcher(HydraConfig.get())
    return how == "submitit_local" or (how == "joblib" and HydraConfig.get().launcher.get("n_jobs", 1) != 1)


def first_rank() -> bool:
    """Whether this process is rank 0 of a distributed run (Lightning's ``LOCAL_RANK``, ``NODE_RANK``,
    Slurm's ``SLURM_PROCID``), or of no such run. The others write no run's files and say nothing."""
    return all(os.environ.get(name, "0").strip() in ("", "0") for name in RANKS)


@contextmanager
def _heeding(stop: Path | None) -> Iterator[None]:
    """While a job of a sweep works, a SIGTERM its command was sent (:class:`Sweeps`) reaches it as
    Ctrl-C: in the command's own process through its handler; in a worker process through a thread
    that reads the :data:`STOPPED` file every 0.2 s and sends the main thread SIGINT per SIGTERM."""
    global _working
    if stop is None or launcher(HydraConfig.get()) in ("basic", "submitit_slurm") or not hasattr(signal, "pthread_kill"):
        yield
        return
    if os.getpid() == _sweep_process:
        _working = True
        try:
            yield
        finally:
            _working = False
        return
    if signal.getsignal(signal.SIGINT) in (signal.SIG_IGN, signal.SIG_DFL, None):  # ignored: as the command (Sweeps) left it
        signal.signal(signal.SIGINT, signal.default_int_handler)  # for submitit_local; SIGINT must not kill the job either
    done, main = threading.Event(), threading.main_thread().ident

    def watch() -> None:
        heard = 0
        while not done.wait(0.2):
            with suppress(OSError):
                if (told := stop.read_text().count("SIGTERM")) > heard:
                    heard = told
                    signal.pthread_kill(main, signal.SIGINT)

    watcher = threading.Thread(target=watch, name="nsp-sweep-stop", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        done.set()
        watcher.join()


def _status(path: Path) -> str | None:
    """A job's status as its ``metrics.json`` says (``completed`` where it names none); None where unreadable."""
    metrics = job_metrics(path.parent)
    return metrics.get("status", "completed") if metrics else None


class RunDirs(Callback):
    """One run per dir. A default (time-stamped) dir taken by a run of the same second gets a fresh
    sibling (``…_2``); a named dir that holds a run's files is refused with one line and
    :data:`BAD_INPUT` before anything is written, except a training run resuming from a checkpoint
    inside it, and a sweep run again with the same command line (it resumes: :func:`run_job`). A
    named dir is claimed while it runs (:func:`_take`). The other processes of a distributed run
    (:func:`first_rank`) join the first one's dir.
    """

    def on_run_start(self, config: DictConfig, **kwargs: Any) -> None:
        self._claim(config, "hydra.run.dir")

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        self._claim(config, "hydra.sweep.dir")

    @staticmethod
    def _claim(config: DictConfig, key: str) -> None:
        HydraConfig.instance().set_config(config)  # the dir's ${hydra:…} parts resolve (run_job sets it too)
        path = Path(OmegaConf.select(config, key))
        if config.get("ckpt_path") and path.resolve() in Path(config.ckpt_path).resolve().parents:
            return  # resuming in place
        if not first_rank():  # another process of a distributed run: the first claims the dir, this one joins it
            with suppress(OSError):
                path.mkdir(parents=True, exist_ok=True)
            return
        try:
            if any(o.split("=", 1)[0].lstrip("+~") == key for o in config.hydra.overrides.hydra):
                RunDirs._named(config, path, key)
            else:
                RunDirs._fresh(config, path, key)
        except OSError as error:  # a parent that is a file, a read-only or full disk
            fail(f"{key}={path}: cannot make a run dir there ({error.strerror or error}); "
                 "name a dir on a disk you can write")

    @staticmethod
    def _named(config: DictConfig, path: Path, key: str) -> None:
        held = path.is_dir() and any(not p.name.startswith(".") and p.suffix != ".log" for p in path.iterdir())  # .hydra, claims
        sweep = key == "hydra.sweep.dir"
        before = _same_overrides(path, config) if held and sweep else None
        if before is not None and before != _swept(config.hydra.overrides.task):
            order = ", ".join(override.split("=", 1)[0] for override in before)
            fail(f"{key}={path} holds this sweep with its swept keys in another order ({order}), which numbers "
                 "its jobs otherwise; give them in that order to resume it")
        if held and before is None:
            fail(f"{key}={path} already holds {'another sweep' if sweep else 'a run'}; name a new dir, or remove "
                 "that one first" + (" (the same command again resumes its own sweep)" if sweep else ""))
        path.mkdir(parents=True, exist_ok=True)
        if not _take(path):
            fail(f"{key}={path} is taken by another {'sweep' if sweep else 'run'} that is still going; name a new dir")
        if held:  # this sweep again: run_job keeps its completed jobs and resumes the others
            (path / STOPPED).unlink(missing_ok=True)
            kept = sum(_status(job / "metrics.json") == "completed" for job in path.iterdir() if (job / ".hydra").is_dir())
            resumes = ", training from its last.ckpt" if "ckpt_path" in config else ""
            print(f"resuming the sweep in {path}: {counted(kept, 'completed job')} kept, the rest run{resumes}", flush=True)

    @staticmethod
    def _fresh(config: DictConfig, path: Path, key: str) -> None:
        fresh, n = path, 1
        while True:  # mkdir claims a name: two runs started in the same second cannot both get it
            try:
                fresh.mkdir(parents=True)
                break
            except FileExistsError:
                n += 1
                fresh = path.with_name(f"{path.name}_{n}")
        with read_write(config.hydra):  # made read-only by HydraConfig above
            OmegaConf.update(config, key, str(fresh))


def _same_overrides(path: Path, config: DictConfig) -> list[str] | None:
    """Where ``path`` holds a sweep (its ``multirun.yaml``) of ``config``'s overrides in any order:
    its overrides that sweep, in its order (which numbers the jobs, and so their dirs); else None."""
    try:
        before = list(OmegaConf.load(path / "multirun.yaml").hydra.overrides.task)
    except (OSError, yaml.YAMLError, OmegaConfBaseException, AttributeError):
        return None
    return _swept(before) if sorted(before) == sorted(config.hydra.overrides.task) else None


def _swept(overrides: Iterable[str]) -> list[str]:
    """The overrides that sweep (``seed=0,1``, ``range(3)``), in their order; one Hydra cannot read counts."""
    parser, swept = OverridesParser.create(), []
    for override in overrides:
        with suppress(OverrideParseException):
            if not parser.parse_override(override).is_sweep_override():
                continue
        swept.append(override)
    return swept


def _take(path: Path) -> bool:
    """Claim a dir the user named for this process: an exclusive ``flock`` on its :data:`CLAIM` file
    (which names the pid, for people), held until the process ends however it ends, so no pid is
    trusted; of two runs started together one gets it. Where the filesystem cannot lock, no claim."""
    try:
        import fcntl
    except ImportError:
        return True
    claim = os.open(path / CLAIM, os.O_RDWR | os.O_CREAT, 0o644)  # not inherited by the programs this one runs
    try:
        fcntl.flock(claim, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as error:
        os.close(claim)
        return error.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)  # held; else: cannot lock here
    os.ftruncate(claim, 0)
    os.write(claim, str(os.getpid()).encode())
    _CLAIMS.append(claim)
    return True


def quote_text(argv: list[str], keys: Iterable[str], sweep: bool = False) -> list[str]:
    """``argv`` with the free-text values of ``keys`` (paths, colours) quoted for Hydra where its
    override grammar cannot read them bare: ``background=#a0522d``, ``image=~/photo (1).jpg``, each item
    of a list (``paints=[#a0522d,#203080]``). In a sweep (``-m``) the commas still separate its values."""
    quoted = []
    for arg in argv:
        key, sep, value = arg.partition("=")
        if sep and value and key.lstrip("+") in keys and ("\\" in value or _unreadable(arg)):  # bare, \\ is one \
            if value.startswith("[") and value.endswith("]"):
                arg = key + "=[" + ",".join(_quoted(item.strip()) for item in value[1:-1].split(",")) + "]"
                quoted.append(arg)
                continue
            pieces = value.split(",") if sweep else [value]
            arg = key + "=" + ",".join(map(_quoted, pieces))
        quoted.append(arg)
    return quoted


def _quoted(text: str) -> str:
    """``text`` in Hydra's single quotes: a quote escaped, and the backslashes just before a quote
    or the closing one doubled (Hydra reads every other backslash as itself)."""
    return "'" + re.sub(r"(\\*)('|$)", lambda m: m.group(1) * 2 + ("\\'" if m.group(2) else ""), text) + "'"


def _unreadable(override: str) -> str | None:
    """Hydra's first line of complaint about one override, or None if it reads."""
    try:
        OverridesParser.create().parse_overrides([override])
    except OverrideParseException as error:
        return str(error).strip().splitlines()[0]
    return None


def options(group: str, default: str) -> str:
    """``${options:GROUP,DEFAULT}`` (the ``--help`` templates): the options of a config group as
    Hydra finds them (YAML files and generated ones), the one a run gets marked with ``*``."""
    found = GlobalHydra.instance().config_loader().get_group_options(group)
    return ", ".join(f"{option}*" if option == default else option for option in found)


OmegaConf.register_new_resolver("options", options, replace=True)


class Console(logging.StreamHandler):
    """The on-screen half of a run's log (``<command>.log`` is the other): each message on
    ``sys.stdout`` as it is at that moment, which a progress bar redirects to keep its place below."""

    stream = property(lambda self: sys.stdout, lambda self, stream: None)


def command(name: str, main: Callable[[DictConfig], Any], schema: Callable[[], Any], text: Iterable[str] = ()) -> None:
    """Run ``python -m nsp.<name>``: its Hydra app ``main`` on the config dir ``conf/<name>``.

    ``-m`` may stand anywhere in the line; ``text`` keys' values are quoted where Hydra needs it;
    ``schema()`` registers the command's structured config (no torch: ``--help`` stays quick). A
    value Hydra rejects while composing ends with one line and :data:`BAD_INPUT`. SIGTERM is Ctrl-C,
    and an interrupt the work has handled ends with :data:`INTERRUPTED`, not a traceback.
    """
    argv = sys.argv[1:]
    sweep = [arg for arg in argv if arg in ("-m", "--multirun")]  # anywhere in the line, as users type it
    multirun = bool(sweep) or any(arg.lstrip("+") == "hydra.mode=MULTIRUN" for arg in argv)
    sys.argv[1:] = sweep + quote_text([arg for arg in argv if arg not in sweep], text, multirun)
    keys = schema()
    signal.signal(signal.SIGTERM, interrupt)
    os.environ["HYDRA_FULL_ERROR"] = "1"  # Hydra raises its errors here instead of printing them over several lines
    try:
        hydra.main(config_path=str(CONF / name), config_name=name, version_base="1.3")(main)()
    except KeyboardInterrupt:
        sys.exit(INTERRUPTED)
    except OverrideParseException:
        arg = next(arg for arg in sys.argv[1:] if "=" in arg and not arg.startswith("-") and _unreadable(arg))
        fail(f"cannot read {arg!r} ({_unreadable(arg)}); quote its value: key='...'")
    except MissingConfigException as error:  # group=option with no such option
        _unmade_sweep()
        group, _, option = (error.missing_cfg_file or "").rpartition("/")
        fail(f"{group}={option}: no such {group}; expected one of: {', '.join(error.options)}" if error.options else _one_line(error))
    except (HydraException, OmegaConfBaseException) as error:  # a value or key the config rejects
        _unmade_sweep()
        fail(did_you_mean(str(error), keys) or _one_line(error))
    except ValueError as error:  # Hydra's own flags that do not go together (-m with --cfg)
        if not str(error).startswith("Only one of"):
            raise
        fail(str(error))
    except OSError as error:  # Hydra's own files (a job's .hydra/, multirun.yaml) on a disk that refuses them
        if error.errno not in REFUSED_WRITES:
            raise
        fail(f"{error.strerror}: {error.filename or 'a run file'}; free space or name another dir (hydra.run.dir, hydra.sweep.dir)", FAILED)


def program(cli: Callable[[], None]) -> None:
    """Run a command's ``cli()`` as the whole process (``python -m nsp.paint``, ``nsp-paint``). Its
    objects are then frozen out of the garbage collector (``gc.freeze``), so Python's tear-down
    frees them without collections that walk all of torch's (most of a second)."""
    try:
        cli()
    finally:
        gc.freeze()


def _unmade_run(out: Path) -> None:
    """A single run refused a value before its work began: its default (time-stamped) dir goes, if
    it holds nothing but what Hydra put there (``.hydra/``, the log), so nothing looks like a run. A
    dir the user named stays: it may have been theirs before."""
    if not first_rank() or any(o.split("=", 1)[0].lstrip("+") == "hydra.run.dir" for o in HydraConfig.get().overrides.hydra):
        return
    if out.is_dir() and all(p.name == ".hydra" or p.suffix == ".log" for p in out.iterdir()):
        shutil.rmtree(out)


def _unmade_sweep() -> None:
    """A sweep that Hydra refused while planning its jobs leaves no dir: the one :class:`RunDirs`
    made goes, if it holds nothing but its claim and Hydra's ``multirun.yaml`` (no job began)."""
    if in_sweep():
        sweep = Path(HydraConfig.get().sweep.dir)
        if sweep.is_dir() and {p.name for p in sweep.iterdir()} <= {CLAIM, "multirun.yaml"}:
            shutil.rmtree(sweep)  # a named dir too: empty before, if it existed, so nothing of the user's is lost


def _one_line(error: BaseException) -> str:
    """Hydra's and OmegaConf's several-line messages as one: the sentences, not the key dumps."""
    parts = []
    for e in (error, error.__cause__):
        for line in str(e or "").splitlines():
            line = line.strip().rstrip(".:")
            if line and not line.startswith(("full_key", "object_type", "reference_type", "Set the environment")) \
                    and not any(line in part for part in parts):
                parts.append(line)
    return ": ".join(parts)


def did_you_mean(message: str, schema: Any) -> str | None:
    """For Hydra's "Could not override 'KEY'" where KEY is a near miss of a key of the command's
    structured config ``schema``: one line with the key meant; None otherwise. Keys under a node the
    schema leaves open (a config group's own keys) are left to Hydra's message."""
    if not (match := re.match(r"Could not override '([^']+)'", message)):
        return None
    node, key = OmegaConf.to_container(OmegaConf.structured(schema)), match.group(1)
    for depth, part in enumerate(key.split(".")):
        if not isinstance(node, dict):
            return None
        if part not in node:
            close = difflib.get_close_matches(part, list(node), n=1)
            where = ".".join(key.split(".")[:depth] + close)
            return f"Could not override '{key}': no such key. Did you mean '{where}'?" if close else None
        node = node[part]
    return None


def fail(message: str, code: int = BAD_INPUT) -> NoReturn:
    """End a command given a bad input (or, ``code`` :data:`FAILED`, a run that could not go on):
    the one line, ``error: …``, and the exit code."""
    print(message if message.startswith("error: ") else f"error: {message}", file=sys.stderr)
    sys.exit(code)
