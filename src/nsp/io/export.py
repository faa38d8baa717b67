"""Paintings as files people open: PNG (the engine), SVG (vector elements), GIF (strokes in order)."""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import torch
from PIL import Image
from torch import Tensor

from nsp.brushes import Brush
from nsp.brushes.svg import image_element
from nsp.colors import hex_color, parse_color
from nsp.engine.canvas import TiledCanvas, paint_canvas
from nsp.errors import BadInput
from nsp.files import atomic_path

EXTENSIONS = (".png", ".svg", ".gif")
GIF_FRAMES = 100  # the most frames of an animation after its empty canvas (nsp.io.export.frame_ends)


def to_uint8(image: Tensor) -> np.ndarray:
    """(3, H, W) in [0, 1] -> (H, W, 3) uint8."""
    return image.detach().clamp(0, 1).mul(255).add_(0.5).to(torch.uint8).permute(1, 2, 0).contiguous().cpu().numpy()


def write_png(path: str | Path, image: Tensor) -> None:
    """Save a (3, H, W) image in [0, 1]."""
    with atomic_path(path) as temporary:
        Image.fromarray(to_uint8(image)).save(temporary, compress_level=3)  # 2× faster than 6, 10 % larger


def write_gif(path: str | Path, brush: Brush, strokes: Tensor, height: int, width: int, background: str = "white",
              frames: int | None = GIF_FRAMES, seconds: float = 4.0, compile: bool | None = None) -> None:
    """An animation of the strokes (N, d) appearing in order (:class:`Animation`), made at once."""
    animation = Animation(brush, len(strokes), height, width, background, frames, compile, strokes.device)
    animation.add(strokes)
    animation.write(path, strokes, seconds)


class Animation:
    """An animation of a painting's strokes appearing in order, its frames made as the strokes come:
    the empty canvas, then one at each of :func:`frame_ends`. :meth:`write` maps every frame to one
    palette, undithered: nothing flickers, and untouched pixels keep their bytes (a small file).

    Args:
        brush, background: the painting's; ``strokes``: how many it has; ``device``: where they are.
        height, width: the animation's size in pixels.
        frames: the most frames after the first, the same strokes each; None: one a stroke.
        compile: shade on the compiled path, its kernels compiled first where missing; None: where
            this machine has them (:func:`~nsp.engine.fused.choose`); False: never.
    """

    def __init__(self, brush: Brush, strokes: int, height: int, width: int, background: str = "white",
                 frames: int | None = GIF_FRAMES, compile: bool | None = None, device: torch.device | str = "cpu"):
        self.brush, self.height, self.width, self.background, self.compile = brush, height, width, background, compile
        self.ends = frame_ends(strokes, frames)
        color = torch.tensor(parse_color(background), device=device)[:, None, None]
        self.canvas = TiledCanvas(color.expand(3, height, width))
        # each frame: the left and top of the pixels its strokes touched, and those pixels (h, w, 3), or None for none
        self.frames: list[tuple[int, int, np.ndarray | None]] = [(0, 0, to_uint8(self.canvas.image()))]
        self.count, self.since = 0, []  # strokes painted; those since the last frame

    def add(self, strokes: Tensor) -> None:
        """Paint the next ``strokes`` (n, d) of the painting, keeping the frames they end."""
        first, count = self.count, len(strokes)
        if not count:
            return
        stops = [end - first for end in self.ends if first < end <= first + count]  # this part's frames
        frames, done = set(stops), 0
        with torch.no_grad():
            for stop in self.canvas.paint_until(self.brush, strokes, stops if stops[-1:] == [count] else stops + [count],
                                                compile=self.compile, first=first):
                self.since.append(strokes[done:stop])
                done = stop
                if stop in frames:
                    left, top, right, bottom = _touched(self.brush, torch.cat(self.since), self.height, self.width)
                    self.since = []
                    pixels = to_uint8(self.canvas.image(top, bottom, left, right)) if right > left and bottom > top else None
                    self.frames.append((left, top, pixels))
        self.count += count

    def write(self, path: str | Path, strokes: Tensor, seconds: float = 4.0) -> None:
        """Save the frames of all the ``strokes`` (N, d), every one added, as a GIF over about
        ``seconds``, the last frame held a second."""
        palette = gif_palette(self.brush, strokes, self.height, self.width, self.background)
        images = [_indexed(self.frames[0][2], palette)]  # each frame kept as a palette image only (1 byte a pixel)
        for left, top, pixels in self.frames[1:]:
            images.append(images[-1].copy())
            if pixels is not None:  # only the pixels the frame's strokes touched are mapped again
                images[-1].paste(_indexed(pixels, palette), (left, top))
        step = max(2, round(100 * seconds / max(len(images) - 1, 1))) * 10  # ms: GIF counts in tens; players slow faster frames
        with atomic_path(path) as temporary:
            images[0].save(temporary, format="GIF", save_all=True, append_images=images[1:],
                           duration=[step] * (len(images) - 1) + [1000], loop=0)


def frame_ends(strokes: int, frames: int | None = GIF_FRAMES) -> list[int]:
    """The strokes shown by each frame of an animation of ``strokes``: 0 (the empty canvas), then
    k more a frame, k = ⌈strokes / frames⌉ (None: 1), the last frame maybe fewer."""
    step = 1 if frames is None else max(1, math.ceil(strokes / frames))
    return [*range(0, strokes, step), strokes] if strokes else [0]


def gif_palette(brush: Brush, strokes: Tensor, height: int, width: int, background: str, side: int = 128) -> Image.Image:
    """256 colours for every frame of an animation: Pillow's octree of the painting drawn small (long side
    ``side``) at each quarter of its strokes, so the colours of strokes later covered count too."""
    scale = min(1.0, side / max(height, width))
    small = (max(1, round(height * scale)), max(1, round(width * scale)))
    cuts, canvas, views = np.linspace(0, len(strokes), 5).round().astype(int), None, []
    with torch.no_grad():
        for start, end in zip(cuts[:-1], cuts[1:]):
            canvas = paint_canvas(brush, strokes[start:end], *small, background, canvas=canvas, first=int(start))
            views.append(to_uint8(canvas))
    return Image.fromarray(np.concatenate(views)).quantize(256, Image.Quantize.FASTOCTREE)


def _touched(brush: Brush, strokes: Tensor, height: int, width: int, margin: int = 2) -> tuple[int, int, int, int]:
    """The pixels strokes (N, d) can change on a ``height``×``width`` canvas: left, top, right, bottom
    (exclusive) of their bounding boxes, widened by ``margin`` for the antialiased edge, as the engine culls."""
    box = brush.extent(strokes.detach(), height, width)  # (N, 4) px: x_min, y_min, x_max, y_max
    left, top = (max(0, math.floor(float(box[:, i].min())) - margin) for i in (0, 1))
    right, bottom = (min(side, math.ceil(float(box[:, i].max())) + margin + 1) for i, side in ((2, width), (3, height)))
    return left, top, right, bottom


def _indexed(pixels: np.ndarray, palette: Image.Image) -> Image.Image:
    """(H, W, 3) uint8 as a palette image of ``palette``'s colours, each pixel its nearest."""
    return Image.fromarray(pixels).quantize(palette=palette, dither=Image.Dither.NONE)


def write_svg(path: str | Path, brush: Brush, strokes: Tensor, height: int, width: int, background: str = "white",
              elements: list[tuple[str, str]] | None = None) -> None:
    """Each stroke as the brush's SVG elements, in painting order, on a ``height``×``width`` canvas;
    a brush whose paint has no vector form (oil's bristles) as each stroke's paint, an image.
    ``elements``: the strokes' (definitions, element) pairs if made already (:func:`painted_elements`)."""
    if elements is None and brush.svg_painted:
        images = []
        with torch.no_grad():
            paint_canvas(brush, strokes.detach().cpu(), height, width, background, images=images)
        elements = painted_elements(images)
    elif elements is None:
        elements = list(brush.svg_elements(strokes.detach().cpu().double().numpy(), height, width))
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="-0.5 -0.5 {width} {height}">',
           "<defs>" + "".join(d for d, _ in elements) + "</defs>",
           f'<rect x="-0.5" y="-0.5" width="{width}" height="{height}" fill="{hex_color(parse_color(background))}"/>',
           *(e for _, e in elements), "</svg>"]
    with atomic_path(path) as temporary:
        temporary.write_text("\n".join(svg))


def painted_elements(images: list[tuple[int, int, Tensor]], workers: int = 1) -> list[tuple[str, str]]:
    """The SVG elements of strokes whose paint has no vector form: each stroke's ``box_images`` image
    (none off the canvas), encoded on ``workers`` threads (PNG compression lets go of the interpreter)."""
    drawn = [image for image in images if image[2].numel()]
    with ThreadPoolExecutor(workers) as pool:
        return [("", element) for element in pool.map(lambda image: image_element(*image[:2], image[2].cpu().numpy()), drawn)]


def write_painting(path: str | Path, brush: Brush, strokes: Tensor, height: int, width: int, background: str,
                   compile: bool | None = None) -> None:
    """Write ``path`` as PNG, SVG or GIF by its extension; ``compile`` as :func:`paint_canvas`'s."""
    suffix = Path(path).suffix.lower()
    if suffix == ".png":
        with torch.no_grad():
            write_png(path, paint_canvas(brush, strokes, height, width, background, compile=compile))
    elif suffix == ".svg":
        write_svg(path, brush, strokes, height, width, background)
    elif suffix == ".gif":
        write_gif(path, brush, strokes, height, width, background, compile=compile)
    else:
        raise BadInput(f"out={path}: unknown extension '{suffix}', expected one of {', '.join(EXTENSIONS)}")
