"""How a run hears Ctrl-C and SIGTERM: both as ``KeyboardInterrupt`` (:func:`interrupt`, SIGTERM's
handler from the commands' start), and neither while it saves what it had (:func:`shielded`)."""
from __future__ import annotations

import signal
from contextlib import contextmanager
from typing import Any, Iterator


def interrupt(signum: int, frame: Any) -> None:
    """A signal handler: the signal as Ctrl-C."""
    raise KeyboardInterrupt


@contextmanager
def shielded() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait while the block runs (saving what an interrupted run had), so a
    second Ctrl-C cannot cut the files short; the first one was already handled."""
    handlers = {sig: signal.signal(sig, signal.SIG_IGN) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
