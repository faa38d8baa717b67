"""Files written whole (:func:`write_json`, :func:`atomic_path` for any format): each is written beside its
place and renamed into it; what a killed writer left (``kill -9``, a power cut) goes with the next write there."""
from __future__ import annotations

import glob
import json
import os
import re
import secrets
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import psutil


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it becomes ``path`` only once the write has
    finished, so an interrupted write leaves the old file or none, never a truncated one. The
    temporary names its process, so those of ended processes are removed here."""
    path = Path(path)
    remove_temporaries(path.parent)
    temporary = path.with_name(f".{path.stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp{path.suffix}")  # suffix: PIL's format
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


TEMPORARY = re.compile(r"\.(?P<stem>.+)\.(?P<pid>\d+)-[0-9a-f]{8}\.tmp(\.[^.]*)?")  # atomic_path's


def remove_temporaries(folder: Path) -> None:
    """Remove the temporaries of :func:`atomic_path` in ``folder`` whose process has ended."""
    if folder.is_dir():
        for entry in folder.glob(".*.tmp*"):
            if (match := TEMPORARY.fullmatch(entry.name)) and entry.is_file() and not running(int(match["pid"])):
                entry.unlink(missing_ok=True)


def remove_leftovers(folder: Path, prefix: str) -> None:
    """Remove the entries ``{prefix}{pid}-…`` of ``folder`` whose process ``pid`` has ended."""
    for entry in folder.glob(f"{glob.escape(prefix)}*-*") if folder.is_dir() else ():
        pid = entry.name[len(prefix):].split("-", 1)[0]
        if pid.isdigit() and not running(int(pid)):
            if entry.is_dir():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)


def running(pid: int) -> bool:
    """Whether process ``pid`` still runs on this machine (a zombie does not; one of another user's
    whose state cannot be read does)."""
    try:
        return psutil.pid_exists(pid) and psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.AccessDenied:
        return True
    except (psutil.NoSuchProcess, OverflowError):  # ended between the two questions; a pid past any process's
        return False


def write_json(path: str | Path, data: dict, indent: int = 2) -> None:
    """Save ``data`` as JSON, atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(json.dumps(data, indent=indent) + "\n")
