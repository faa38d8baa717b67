"""``python -m nsp.app [port=7860] [host=127.0.0.1]``: paint in the browser. A Gradio app: upload, paste
or pick a photo, choose the brush, the strokes and a style, watch the painting level by level, stop it
and keep what was painted, download its files, re-render it at any size. Its endpoint ``/paint``
(image, brush, strokes -> the painting and its files) serves ``gradio_client`` and scripts.

Safe by default: it listens on 127.0.0.1 unless ``host=`` says otherwise; an upload is read as
``image=`` is (type, size, decompression bombs: one line saying what is wrong); paintings queue, one at
a time, each browser session's files in a folder of its own, removed when the session ends; the
browser sends pictures and choices, never a path.
"""
import atexit
import queue
import shutil
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, Optional

from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig

from nsp.cli import command, fail, program
from nsp.config import BRUSH_NAMES
from nsp.errors import BadInput

TEXT = ("host",)
SHOWN = ("final.png", "painting.svg", "strokes.json", "animation.gif")  # what a painting offers for download


@dataclass
class AppConfig:
    port: int = 7860
    host: str = "127.0.0.1"  # 0.0.0.0 serves other machines too: only on a network you trust
    strokes: int = 300  # the strokes slider's start
    max_strokes: int = 3000  # and its end
    max_upload_mb: int = 20  # an upload larger than this is refused before it is read
    threads: Optional[int] = None  # torch CPU threads a painting uses; None: torch's default


ConfigStore.instance().store(name="app_schema", node=AppConfig)


class Studio:
    """The app's state: a folder a browser session, each holding that session's paintings, and the
    painting under way (its session, its stop flag). The paintings run one at a time (the queue)."""

    def __init__(self, threads: int | None = None):
        self.root = Path(tempfile.mkdtemp(prefix="nsp-app-"))
        self.threads = threads
        self.stop = threading.Event()
        self.running: str | None = None  # the session whose painting is under way
        self.latest: dict[str, Path] = {}  # each session's last painting's folder
        atexit.register(shutil.rmtree, self.root, ignore_errors=True)

    def folder(self, session: str) -> Path:
        """A new, empty folder for a painting of the browser session ``session``."""
        base = self.root / "".join(c for c in session if c.isalnum())[:64]
        base.mkdir(exist_ok=True)
        return Path(tempfile.mkdtemp(prefix="painting-", dir=base))

    def close(self, session: str) -> None:
        """The session ended: its files go."""
        self.latest.pop(session, None)
        shutil.rmtree(self.root / "".join(c for c in session if c.isalnum())[:64], ignore_errors=True)

    def paint(self, photo: "Upload | None", brush: str, strokes: int, style: "Upload | None", session: str,
              progress: Callable[[float, str], None] = lambda share, said: None) -> Iterator[tuple]:
        """Paint the upload ``photo`` into a new folder of ``session``: yields (picture, what is
        happening, files) at each level's end (the canvas so far, (H, W, 3) uint8) and at the end (the
        painting's final.png, or what was painted before Stop); ``progress(share, said)`` hears each
        stroke placed. :class:`BadInput` for a photo nsp cannot read."""
        import nsp

        if not photo:
            raise BadInput("no photo: upload or paste one, or pick a built-in photo")
        image = read(photo, "photo")
        if style:
            read(style, "style image")
        folder = self.folder(session)
        events: queue.Queue = queue.Queue()
        self.stop.clear()
        self.running = session
        watch = Watch(self.stop, events)
        options = {"brush": brush, "strokes": int(strokes), "progress": False, "threads": self.threads}
        if style:
            options["style.image"] = style.path
        outcome: dict[str, Any] = {}

        def work() -> None:
            try:
                outcome["painting"] = nsp.paint(image, out=folder, callbacks=[watch], **options)
            except BaseException as error:  # noqa: BLE001  (told to the browser, below)
                outcome["error"] = error
            finally:
                self.running = None
                events.put(None)

        worker = threading.Thread(target=work, name="nsp-painting", daemon=True)
        worker.start()
        while (event := events.get()) is not None:
            placed, canvas = event
            said = f"{placed} of {strokes} strokes placed…"
            progress(placed / strokes, said)
            if canvas is not None:
                yield canvas, said, []
        worker.join()
        if "error" in outcome:
            error = outcome["error"]
            if isinstance(error, KeyboardInterrupt):  # stopped before a stroke was painted
                yield None, "stopped before the first stroke", []
                return
            raise error
        painting = self.latest[session] = outcome["painting"]
        files = [str(folder / name) for name in SHOWN if (folder / name).is_file()]
        if painting.metrics:
            said = f"{len(painting.strokes.strokes)} {brush} strokes, PSNR {painting.metrics['psnr']:.2f} dB"
        else:
            said = f"stopped: {len(painting.strokes.strokes)} {brush} strokes kept"
        yield str(folder / "final.png"), said, files

    def halt(self, session: str) -> None:
        """Stop the painting under way if it is ``session``'s (another browser's goes on)."""
        if self.running == session:
            self.stop.set()

    def rerender(self, size: int, session: str) -> str:
        """``session``'s last painting drawn at long side ``size``: the PNG's path."""
        from PIL import Image

        painting = self.latest.get(session)
        if painting is None:
            raise BadInput("nothing to re-render yet: paint first")
        out = painting.folder / f"painting_{int(size)}px.png"
        Image.fromarray(painting.render(int(size))).save(out)
        return str(out)


class Upload:
    """A file the browser sent, as Gradio saved it: ``path`` (in its upload folder, which Gradio checks)
    and the name it had (``orig_name``)."""

    def __init__(self, path: str, orig_name: Optional[str] = None, **_: Any):  # Gradio's other keys (url, size, …)
        self.path, self.orig_name = path, orig_name


def read(upload: Upload, key: str):
    """``upload`` as ``image=`` is read (type, size, decompression bombs checked): (3, H, W); :class:`BadInput`
    saying what is wrong in one line, naming the upload by its name, not by where it lies."""
    from nsp.images import load_image

    try:
        return load_image(upload.path, key=key)
    except BadInput as error:
        name = upload.orig_name or Path(upload.path).name
        message = str(error).replace(f"={upload.path}", f" {name}").replace(upload.path, name)
        raise BadInput(message.split("; give a PNG")[0]) from None


class Watch:
    """A painter callback (:class:`nsp.painter.painter.Callback`) that tells the app each finished level's
    canvas and stops the painting when ``stop`` is set (as Ctrl-C would: what was painted is kept)."""

    def __init__(self, stop: threading.Event, events: queue.Queue):
        self.stop, self.events, self.placed = stop, events, 0

    def on_strokes(self, painter, added: int) -> None:
        self.placed += added
        self.events.put((self.placed, None))
        self._heed()

    def on_step(self, painter, step: int, losses) -> None:
        self._heed()

    def on_level(self, painter, level: int, canvas) -> None:
        from nsp.io.export import to_uint8

        self.events.put((self.placed, to_uint8(canvas.detach().cpu())))

    def _heed(self) -> None:
        if self.stop.is_set():
            raise KeyboardInterrupt


def build(cfg: AppConfig | DictConfig, studio: Studio):
    """The Gradio app (``gradio.Blocks``) of ``studio``; not yet launched."""
    import gradio as gr

    from nsp.images import BUILTIN, load_image
    from nsp.io.export import to_uint8

    def paint(photo, brush, strokes, style=None, request: gr.Request = None, progress=gr.Progress()):
        """The uploads come unread (``preprocess=False``: Gradio's own decoding would stop a text file or
        a decompression bomb with a stack of its internals), as the files Gradio saved them to."""
        session = request.session_hash if request is not None and request.session_hash else "api"
        photo, style = (Upload(**image) if image else None for image in (photo, style))
        try:
            for canvas, said, files in studio.paint(photo, brush, int(strokes), style, session,
                                                    lambda share, said: progress(share, desc=said)):
                yield canvas, said, files
        except BadInput as error:
            raise gr.Error(str(error), print_exception=False) from None

    def builtin(name):
        return to_uint8(load_image(name)) if name else None

    def stop(request: gr.Request):
        studio.halt(request.session_hash)

    def rerender(size, request: gr.Request):
        try:
            return studio.rerender(size, request.session_hash)
        except BadInput as error:
            raise gr.Error(str(error), print_exception=False) from None

    with gr.Blocks(title="nsp: paint a photo with strokes", delete_cache=(600, 3600)) as app:
        gr.Markdown("# nsp\nA photo in, a painting of brush strokes out: watch it appear level by level.")
        with gr.Row():
            with gr.Column():
                photo = gr.Image(label="Photo", type="filepath", format="png", sources=["upload", "clipboard"],
                                 elem_id="photo")
                pick = gr.Dropdown([None, *BUILTIN], value=None, label="or a built-in photo", elem_id="builtin")
                brush = gr.Dropdown(list(BRUSH_NAMES), value="oilpaint", label="Brush", elem_id="brush")
                strokes = gr.Slider(10, cfg.max_strokes, value=cfg.strokes, step=10, label="Strokes", elem_id="strokes")
                style = gr.Image(label="Style image (optional)", type="filepath", format="png",
                                 sources=["upload", "clipboard"], elem_id="style")
                with gr.Row():
                    start = gr.Button("Paint", variant="primary", elem_id="paint")
                    halt = gr.Button("Stop", variant="stop", elem_id="stop")
            with gr.Column():
                canvas = gr.Image(label="Painting", type="filepath", format="png", interactive=False, elem_id="canvas")
                status = gr.Markdown(elem_id="status")
                files = gr.File(label="Files", file_count="multiple", interactive=False, elem_id="files")
                with gr.Row():
                    size = gr.Number(2048, label="Re-render at (long side, px)", minimum=16, precision=0, elem_id="rerender_size")
                    again = gr.Button("Re-render", elem_id="rerender")
                bigger = gr.File(label="Re-rendered", interactive=False, elem_id="rerendered")
        pick.change(builtin, pick, photo, api_name=False)
        start.click(paint, [photo, brush, strokes, style], [canvas, status, files], api_name="paint", preprocess=False,
                    concurrency_id="painting", concurrency_limit=1)
        halt.click(stop, None, None, api_name=False, queue=False)
        again.click(rerender, size, bigger, api_name=False, concurrency_id="painting")
        def close(request: gr.Request):
            studio.close(request.session_hash)

        app.unload(close)
    return app


def main(cfg: DictConfig) -> None:
    try:
        import gradio  # noqa: F401
    except ImportError:
        fail("the app needs Gradio: pip install 'nsp[app]' (make setup installs it)")
    if not 0 < cfg.port < 65536:
        fail(f"port={cfg.port}: expected a port from 1 to 65535")
    if not 10 <= cfg.strokes <= cfg.max_strokes:
        fail(f"strokes={cfg.strokes}: expected from 10 to max_strokes={cfg.max_strokes}")
    from hydra.core.global_hydra import GlobalHydra

    GlobalHydra.instance().clear()  # each painting composes its config as nsp.paint(...) does
    studio = Studio(cfg.threads)
    app = build(cfg, studio)
    print(f"nsp.app: painting in the browser at http://{cfg.host}:{cfg.port} (its files in {studio.root}; Ctrl-C stops)",
          flush=True)
    app.queue(default_concurrency_limit=1).launch(server_name=cfg.host, server_port=cfg.port, quiet=True, show_error=True,
                                                  max_file_size=f"{cfg.max_upload_mb}mb", allowed_paths=[str(studio.root)],
                                                  footer_links=["api"])


def cli() -> None:
    """The command line: ``python -m nsp.app``."""
    command("app", main, AppConfig, text=TEXT)


def run() -> None:
    """``python -m nsp.app`` and ``nsp-app``: :func:`cli` as the whole process."""
    program(cli)


if __name__ == "__main__":
    run()
