"""A painting's files: final.png, strokes.json, painting.svg, animation.gif, and its scores."""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.colors import parse_color
from nsp.engine import paint_canvas
from nsp.engine.canvas import TiledCanvas
from nsp.images import long_side, psnr, resize, ssim
from nsp.io.export import Animation, painted_elements, write_png, write_svg
from nsp.io.strokes import StrokeFile, save_strokes
from nsp.painter.schema import SCORE_SIZE


def write_strokes_and_png(out: Path, strokes: Tensor, brush: Brush, aspect: tuple[int, int], background: str,
                          render_size: int) -> None:
    """Write ``strokes.json`` and ``final.png`` (the engine, long side ``render_size``) of strokes
    (N, d) painted on a canvas of ``aspect`` (height, width): what an interrupted run keeps."""
    height, width = long_side(*aspect, render_size)
    save_strokes(out / "strokes.json", StrokeFile(brush, strokes, height, width, background))
    with torch.no_grad():
        write_png(out / "final.png", paint_canvas(brush, strokes, height, width, background))


class PaintingFiles:
    """A painting's files: :meth:`finish` paints its strokes onto final.png's canvas and the GIF's
    frames, makes their SVG elements (images, for a brush whose paint has no vector form), and
    writes every file (:func:`write_files`).

    Args:
        out: the run dir.
        brush, background: the painting's.
        photo: (3, H, W) in [0, 1], the photo painted: its aspect is the canvas's (final.png and
            painting.svg have a long side of ``render_size``, animation.gif of ``animation_size``),
            and the scores compare the painting with it.
        frames: animation.gif's most frames after the empty canvas (None: one a stroke).
        strokes: how many the painting has.
        workers: threads (of one torch thread each) the work is shared on.
        device: where the strokes are, and the canvases are painted.
        compile: shade final.png's and the GIF's strokes on the engine's compiled kernels: True,
            compiled first where this machine has none; None (auto), where it has them
            (``python -m nsp.engine`` compiles them; :func:`nsp.engine.fused.choose`); False, never.
    """

    def __init__(self, out: Path, brush: Brush, photo: Tensor, background: str, render_size: int,
                 animation_size: int, frames: int | None, strokes: int, workers: int = 1, device: torch.device | str = "cpu",
                 compile: bool | None = None):
        self.out, self.brush, self.background, self.workers, self.compile = out, brush, background, workers, compile
        aspect = photo.shape[-2:]
        self.photo = resize(photo.cpu(), long_side(*aspect, SCORE_SIZE))  # as similarity() compares it
        self.height, self.width = long_side(*aspect, render_size)
        color = torch.tensor(parse_color(background), device=device)[:, None, None]
        self.canvas = TiledCanvas(color.expand(3, self.height, self.width))
        self.animation = Animation(brush, strokes, *long_side(*aspect, animation_size), background, frames, compile,
                                   device)
        self.elements: list[tuple[str, str]] = []  # painting.svg's, of the strokes painted
        self.count = 0  # strokes painted

    def _paint(self, strokes: Tensor) -> None:
        """Paint the next ``strokes`` (n, d) onto final.png's canvas, and make their SVG elements."""
        images = [] if self.brush.svg_painted else None
        with torch.no_grad():
            self.canvas.paint(self.brush, strokes, compile=self.compile, first=self.count, images=images)
        if images is None:
            self.elements += self.brush.svg_elements(strokes.detach().cpu().double().numpy(), self.height, self.width,
                                                     self.count)
        else:
            self.elements += painted_elements(images, self.workers)
        self.count += len(strokes)

    def finish(self, strokes: Tensor) -> dict[str, float]:
        """Write ``strokes.json`` of all the painting's ``strokes`` (N, d) first (a process killed
        while it draws the rest keeps the painting itself), then ``final.png``, ``painting.svg`` and,
        beside them, ``animation.gif``; returns final.png's :func:`similarity` to the photo."""
        save_strokes(self.out / "strokes.json", StrokeFile(self.brush, strokes, self.height, self.width, self.background))
        threads = torch.get_num_threads()
        torch.set_num_threads(1)  # a file a core: each file's ops are too small to split well
        try:
            with ThreadPoolExecutor(1) as pool:
                gif = pool.submit(self._write_gif, strokes)
                self._paint(strokes[self.count:])
                final = self.canvas.image()
                write_png(self.out / "final.png", final)
                write_svg(self.out / "painting.svg", self.brush, strokes, self.height, self.width, self.background,
                          self.elements)
                scores = similarity(final, self.photo)
                gif.result()
                return scores
        finally:
            torch.set_num_threads(threads)

    def _write_gif(self, strokes: Tensor) -> None:
        if len(strokes) != self.animation.ends[-1]:
            raise ValueError(f"{len(strokes)} strokes, where the painting was to have {self.animation.ends[-1]}")
        self.animation.add(strokes[self.animation.count:])
        self.animation.write(self.out / "animation.gif", strokes)


def write_files(out: Path, strokes: Tensor, brush: Brush, photo: Tensor, background: str, render_size: int,
                animation_size: int, frames: int | None, workers: int, compile: bool | None = None) -> dict[str, float]:
    """Write every file of a painting of ``strokes`` (N, d) of ``photo`` (3, H, W) at once
    (:class:`PaintingFiles`, on ``workers`` threads, ``compile`` as its); returns final.png's
    :func:`similarity` to it."""
    files = PaintingFiles(out, brush, photo, background, render_size, animation_size, frames, len(strokes), workers,
                          strokes.device, compile)
    return files.finish(strokes)


def similarity(painting: Tensor, photo: Tensor) -> dict[str, float]:
    """PSNR (dB) and SSIM of a painting against its photo, both (3, ·, ·) in [0, 1], compared at a
    256-pixel long side (SSIM with Wang et al.'s Gaussian window, σ = 1.5, as torchmetrics)."""
    shape = long_side(*photo.shape[-2:], SCORE_SIZE)  # the painting's own rounding may differ by a pixel
    a, b = (resize(image.cpu(), shape).double() for image in (painting, photo))
    return {"psnr": round(float(psnr(a, b)), 3), "ssim": round(float(ssim(a, b)), 4)}
