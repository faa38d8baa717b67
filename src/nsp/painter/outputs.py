"""A painting's files: final.png, strokes.json, painting.svg, animation.gif, and its scores."""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import torch
from torch import Tensor

from nsp.brushes import Brush
from nsp.engine import paint_canvas
from nsp.images import long_side, psnr, resize, ssim
from nsp.io.export import write_gif, write_png, write_svg
from nsp.io.strokes import StrokeFile, save_strokes

SCORE_SIZE = 256  # long side at which psnr and ssim compare the painting with the photo


def write_strokes_and_png(out: Path, strokes: Tensor, brush: Brush, aspect: tuple[int, int], background: str,
                          render_size: int, images: list | None = None) -> Tensor:
    """Write ``strokes.json`` and ``final.png`` (the engine, long side ``render_size``) of strokes
    (N, d) painted on a canvas of ``aspect`` (height, width); returns the image (3, h, w).
    ``images``, if given, gets each stroke's image from the same render (see :func:`write_svg`)."""
    height, width = long_side(*aspect, render_size)
    save_strokes(out / "strokes.json", StrokeFile(brush, strokes, height, width, background))
    with torch.no_grad():
        final = paint_canvas(brush, strokes, height, width, background, images=images)
    write_png(out / "final.png", final)
    return final


def write_files(out: Path, strokes: Tensor, brush: Brush, aspect: tuple[int, int], background: str, render_size: int,
                animation_size: int, frames: int | None, photo: Tensor, workers: int) -> dict[str, float]:
    """Write every file of a painting: ``strokes.json`` and ``final.png`` (:func:`write_strokes_and_png`),
    ``painting.svg`` (long side ``render_size``) and ``animation.gif`` (strokes in order, long side
    ``animation_size``, at most ``frames`` frames after the empty canvas; None: one a stroke), on
    ``workers`` threads of one torch thread each (the files are independent, but for an SVG of
    stroke images, which final.png's render makes); returns final.png's :func:`similarity` to ``photo``."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # a file a core: each file's ops are too small to split well
    images = [] if brush.svg_painted else None
    try:
        with ThreadPoolExecutor(workers) as pool:  # the longest first

            def write_painting_svg() -> None:
                if images is not None:
                    final.result()  # its render makes them
                write_svg(out / "painting.svg", brush, strokes, *long_side(*aspect, render_size), background, images,
                          workers)  # final.png's render done, its images are encoded on every core

            vector = images is None  # a vector SVG is written a stroke at a time in Python: the longest, first
            svg = pool.submit(write_painting_svg) if vector else None
            final = pool.submit(write_strokes_and_png, out, strokes, brush, aspect, background, render_size, images)
            gif = pool.submit(write_gif, out / "animation.gif", brush, strokes, *long_side(*aspect, animation_size),
                              background, frames=frames)
            svg = svg if vector else pool.submit(write_painting_svg)  # after final.png's render, whose images it takes
            scores = similarity(final.result(), photo)  # while the GIF and the SVG are written
            svg.result(), gif.result()
            return scores
    finally:
        torch.set_num_threads(threads)


def similarity(painting: Tensor, photo: Tensor) -> dict[str, float]:
    """PSNR (dB) and SSIM of a painting against its photo, both (3, ·, ·) in [0, 1], compared at a
    256-pixel long side (SSIM with Wang et al.'s Gaussian window, σ = 1.5, as torchmetrics)."""
    shape = long_side(*photo.shape[-2:], SCORE_SIZE)  # the painting's own rounding may differ by a pixel
    a, b = (resize(image.cpu(), shape).double() for image in (painting, photo))
    return {"psnr": round(float(psnr(a, b)), 3), "ssim": round(float(ssim(a, b)), 4)}
