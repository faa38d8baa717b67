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
from nsp.io.plot import write_plot
from nsp.io.strokes import StrokeFile, save_strokes
from nsp.painting.schema import SCORE_SIZE


def write_strokes_and_png(out: Path, strokes: Tensor, brush: Brush, aspect: tuple[int, int], background: str,
                          render_size: int) -> None:
    """Write ``strokes.json`` and ``final.png`` (the engine, long side ``render_size``) of strokes
    (N, d) painted on a canvas of ``aspect`` (height, width): what an interrupted run keeps."""
    height, width = long_side(*aspect, render_size)
    save_strokes(out / "strokes.json", StrokeFile(brush, strokes, height, width, background))
    with torch.no_grad():
        write_png(out / "final.png", paint_canvas(brush, strokes, height, width, background))


def write_files(out: Path, strokes: Tensor, brush: Brush, photo: Tensor, background: str, render_size: int,
                animation_size: int, frames: int | None, workers: int, compile: bool | None = None,
                paints: list[str] | None = None) -> dict[str, float]:
    """Write every file of a painting of ``strokes`` (N, d) into the run dir ``out``; returns final.png's
    :func:`similarity` to ``photo``. ``strokes.json`` comes first (a process killed while it draws the
    rest keeps the painting), then final.png and painting.svg, while a thread draws animation.gif.

    Args:
        photo: (3, H, W) in [0, 1], the photo painted: its aspect is the canvas's.
        render_size, animation_size: the long sides of final.png and painting.svg, and of animation.gif.
        frames: animation.gif's most frames after the empty canvas (None: one a stroke).
        workers: threads the SVG's painted images (a brush whose paint has no vector form) are encoded on.
        compile: shade on the engine's compiled kernels: True, compiled first where missing; None, where
            this machine has them (:func:`nsp.engine.fused.choose`); False, never.
        paints: the painting's paints (``#rrggbb``, layer by layer), each stroke one of them: plot.svg too.
    """
    aspect = photo.shape[-2:]
    photo = resize(photo.cpu(), long_side(*aspect, SCORE_SIZE))  # as similarity() compares it
    height, width = long_side(*aspect, render_size)
    save_strokes(out / "strokes.json", StrokeFile(brush, strokes, height, width, background, paints))
    color = torch.tensor(parse_color(background), device=strokes.device)[:, None, None]
    canvas = TiledCanvas(color.expand(3, height, width))
    animation = Animation(brush, len(strokes), *long_side(*aspect, animation_size), background, frames, compile,
                          strokes.device)

    def write_gif() -> None:
        animation.add(strokes)
        animation.write(out / "animation.gif", strokes)

    with ThreadPoolExecutor(1) as pool:
        gif = pool.submit(write_gif)
        images = [] if brush.svg_painted else None
        with torch.no_grad():
            canvas.paint(brush, strokes, compile=compile, images=images)
        if images is None:
            elements = list(brush.svg_elements(strokes.detach().cpu().double().numpy(), height, width))
        else:
            elements = painted_elements(images, workers)
        final = canvas.image()
        write_png(out / "final.png", final)
        write_svg(out / "painting.svg", brush, strokes, height, width, background, elements)
        if paints is not None:
            write_plot(out / "plot.svg", brush, strokes, paints, height, width)
        scores = similarity(final, photo)
        gif.result()
        return scores


def similarity(painting: Tensor, photo: Tensor) -> dict[str, float]:
    """PSNR (dB) and SSIM of a painting against its photo, both (3, ·, ·) in [0, 1], compared at a
    256-pixel long side (SSIM with Wang et al.'s Gaussian window, σ = 1.5, as torchmetrics)."""
    shape = long_side(*photo.shape[-2:], SCORE_SIZE)  # the painting's own rounding may differ by a pixel
    a, b = (resize(image.cpu(), shape).double() for image in (painting, photo))
    return {"psnr": round(float(psnr(a, b)), 3), "ssim": round(float(ssim(a, b)), 4)}
