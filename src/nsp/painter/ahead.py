"""A painting's files made ahead, in a process of their own, while it is painted.

``python -m nsp.paint`` on a machine of two cores or more starts this process before it reads its
config, so the process loads scikit-image's face cascade while Hydra composes, and imports torch
beside the command's own import. Then it finds the photo's faces
(:func:`~nsp.painter.faces.find_faces`) while the command builds its painter. Each finished level's
strokes then come to it, and it paints them into final.png's canvas, the GIF's frames and the SVG's
elements (:class:`~nsp.painter.outputs.PaintingFiles`) while the painter paints the next level: on
one thread while this process works, on all of torch's while it is idle
(:class:`~nsp.painter.callbacks.SendLevels`). Once the last level is done, only its strokes and the
encoding are left. The files are those :func:`~nsp.painter.outputs.write_files` would write.

The command's half imports no torch. The process runs ``python -m nsp.painter.ahead PID FD`` and
takes pickled messages on its stdin: first ``("faces", image, side, work_size)`` (the faces to
find; ``image`` None: none), then ``("begin", out, brush, …)`` (:class:`~nsp.painter.outputs.PaintingFiles`'
settings), ``("add", strokes)`` a level, and ``("finish", strokes)``. It answers on its stdout with
the faces, where asked, then the scores; it writes a byte to the pipe ``FD`` once started and
after each ``add``.
"""
from __future__ import annotations

import ctypes
import logging
import os
import pickle
import queue
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)
PR_SET_PDEATHSIG = 1  # prctl's option: the signal a process gets when its parent ends


class FilesAhead:
    """The command's end of the process: :meth:`begin`, :meth:`add` as levels finish, then
    :meth:`finish`, after :meth:`look_for_faces`; :meth:`close` ends the process, done or not (an
    interrupted painting, or a config that writes the files after all). :meth:`working` tells
    whether it is busy, so the painter may take both cores while it is not.
    """

    def __init__(self):
        self.errors = tempfile.TemporaryFile()  # what the process says on stderr, told if it fails
        self.done, done = os.pipe()  # a byte from the process for its start (its imports), and for each add done
        self.process = subprocess.Popen([sys.executable, "-m", __name__, str(os.getpid()), str(done)],
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.errors,
                                        pass_fds=(done,))
        os.close(done)
        os.set_blocking(self.done, False)
        self.pending = 1  # its start
        self.searching = False  # whether the faces' answer is yet to be read
        self.outbox: queue.SimpleQueue = queue.SimpleQueue()
        threading.Thread(target=self._send, daemon=True).start()

    def look_for_faces(self, image: str | None, side: int = 0, work_size: int = 0) -> None:
        """The first message: find the faces of ``image`` (a path or a built-in photo's name, read
        at long side ``side`` and searched at ``work_size``, as the painter's target is made), which
        :meth:`faces` answers; None: no search."""
        self.searching = image is not None
        self.outbox.put(("faces", image, side, work_size))

    def working(self) -> bool:
        """Whether the process is still at work on what it was given: its start or strokes (not
        when it has ended)."""
        try:
            read = os.read(self.done, 64)
        except BlockingIOError:  # nothing new
            return self.pending > 0
        self.pending = self.pending - len(read) if read else 0  # b"": it has ended
        return self.pending > 0

    def _send(self) -> None:
        """Pipe the messages to the process, on a thread of its own: the painter never waits on a full pipe."""
        try:
            while (message := self.outbox.get()) is not None:
                pickle.dump(message, self.process.stdin, protocol=pickle.HIGHEST_PROTOCOL)
                self.process.stdin.flush()
            self.process.stdin.close()
        except (OSError, ValueError):  # the process has ended (finish tells), or was closed
            pass

    def faces(self) -> list | None:
        """The faces found, as :class:`~nsp.painter.faces.Box` es, once found; None where the
        search failed or was not asked for (the caller then searches)."""
        if not self.searching:
            return None
        self.searching = False
        try:
            return pickle.load(self.process.stdout)
        except (EOFError, pickle.UnpicklingError):  # the process has ended: finish tells why
            return None

    def begin(self, out: Path, brush: dict[str, Any], photo, background: str, render_size: int, animation_size: int,
              frames: int | None, strokes: int) -> None:
        """The painting's files go to ``out``, of the brush ``get_brush(**brush)`` (see
        :class:`~nsp.painter.outputs.PaintingFiles` for the rest)."""
        self.outbox.put(("begin", str(out), brush, photo.detach().cpu().numpy(), background, render_size, animation_size,
                         frames, strokes))

    def add(self, strokes) -> None:
        """The painting's next strokes (n, d), a finished level's."""
        self.pending += 1
        self.outbox.put(("add", strokes.detach().cpu().numpy()))

    def finish(self, strokes) -> dict[str, float] | None:
        """Write the files of all the ``strokes`` (N, d) (:meth:`PaintingFiles.finish
        <nsp.painter.outputs.PaintingFiles.finish>`); their scores against the photo, or None where
        the process failed (a warning tells why; the caller writes the files itself). Raises the
        ``OSError`` a file met (a full disk), as writing it here would have."""
        self.outbox.put(("finish", strokes.detach().cpu().numpy()))
        self.outbox.put(None)
        self.faces()  # an answer not read comes first
        try:
            answer = pickle.load(self.process.stdout)  # once every file is written, or one could not be
        except (EOFError, pickle.UnpicklingError):
            answer = None
        if isinstance(answer, OSError):
            raise answer
        if answer is None:
            self.process.wait()
            self.errors.seek(0)
            said = self.errors.read().decode(errors="replace").strip().splitlines()
            log.warning(f"the process writing the files failed ({said[-1] if said else f'exit {self.process.returncode}'}); "
                        "writing them here")
        return answer

    def close(self) -> None:
        """End the process (at once if it is still at work) and let go of its pipes; again, nothing."""
        if self.errors.closed:
            return
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        for pipe in (self.process.stdin, self.process.stdout):
            try:
                pipe.close()
            except OSError:  # a flush into the pipe of a killed process
                pass
        self.errors.close()
        os.close(self.done)


def main() -> None:
    """The process: its messages, in order, until ``finish`` (or the command's end)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the command's: it ends this process once it has kept what it had
    _end_with(int(sys.argv[1]))
    done = int(sys.argv[2])
    from nsp.painter.faces import cascade

    try:
        cascade()  # before torch: the command is still reading its config
    except ImportError:  # the search fails, and the command searches itself and tells why
        pass
    import torch

    torch.set_num_threads(1)  # the painter has the other core
    inbox, answers, files = sys.stdin.buffer, os.fdopen(os.dup(1), "wb"), None
    os.dup2(2, 1)  # whatever else writes to stdout goes to stderr, not into the answer
    try:
        _, image, side, work_size = pickle.load(inbox)  # the faces first, as soon as torch is in: the painter waits on them
    except EOFError:  # the command ended, or writes the files itself
        return
    if image is not None:
        pickle.dump(_faces(image, side, work_size), answers)
        answers.flush()
    from nsp.brushes import get_brush
    from nsp.painter.outputs import PaintingFiles

    os.write(done, b".")  # started
    while True:
        try:
            kind, *args = pickle.load(inbox)
        except EOFError:  # the command ended without asking for the files
            return
        if kind == "begin":
            out, brush, photo, *settings = args
            files = PaintingFiles(Path(out), get_brush(**brush), torch.from_numpy(photo), *settings)
        elif kind == "add":
            files.add(torch.from_numpy(args[0]))
            os.write(done, b".")
        else:
            try:
                answer = files.finish(torch.from_numpy(args[0]))
            except OSError as error:  # the command's to tell (a full disk): it stops as if it had met it
                answer = OSError(error.errno, error.strerror, error.filename)
            pickle.dump(answer, answers)
            answers.flush()
            os._exit(0)  # without Python's tear-down after torch (0.4 s), which the command would wait for


def _faces(image: str, side: int, work_size: int) -> list | None:
    """The faces in the painter's target of ``image`` (:meth:`FilesAhead.look_for_faces`); None where
    it cannot be read: the command's own checks tell why."""
    from nsp.images import load_image, resize
    from nsp.painter.faces import find_faces

    try:
        return find_faces(resize(load_image(image, max_side=side), work_size))
    except Exception:  # noqa: BLE001 — any failure: the command searches itself, and fails as it would have
        return None


def _end_with(command: int) -> None:
    """Be killed when the process ``command`` ends, however it ends (kill -9 too), where Linux
    offers it (``PR_SET_PDEATHSIG``), rather than go on writing files into a run nothing waits on."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):  # not Linux: the end of the messages ends it
        return
    if os.getppid() != command:  # it ended before that was asked
        os._exit(0)


if __name__ == "__main__":
    main()
