"""How a run hears Ctrl-C and SIGTERM: both as ``KeyboardInterrupt`` (:func:`interrupt`, SIGTERM's
handler from the commands' start), while torch loads too (:func:`numpy_before_torch`), and neither
while it saves what it had (:func:`shielded`)."""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Any, Iterator


def interrupt(signum: int, frame: Any) -> None:
    """A signal handler: the signal as Ctrl-C."""
    raise KeyboardInterrupt


@contextmanager
def shielded() -> Iterator[None]:
    """Ignore Ctrl-C and SIGTERM while the block saves what an interrupted run had: a second Ctrl-C
    cannot cut the files short. Off the main thread (a painting an app runs), signals are not its own: nothing to do."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    handlers = {sig: signal.signal(sig, signal.SIG_IGN) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


def numpy_before_torch() -> None:
    """Import numpy before torch: torch's own import of it swallows a Ctrl-C that lands there."""
    import numpy  # noqa: F401
