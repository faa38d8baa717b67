"""Paintings as files people open: PNG (the engine), SVG (vector elements), GIF (strokes in order)."""
from __future__ import annotations

import json
import base64
import io
import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import torch
from PIL import Image
from torch import Tensor

from nsp.brushes import Brush
from nsp.brushes.oilpaint import _OPAQUE
from nsp.engine.canvas import paint_canvas, parse_color

EXTENSIONS = (".png", ".svg", ".gif")
GIF_FRAMES = 50  # frames of an animation after its empty canvas


def to_uint8(image: Tensor) -> np.ndarray:
    """(3, H, W) in [0, 1] -> (H, W, 3) uint8."""
    return (image.detach().clamp(0, 1).permute(1, 2, 0).cpu().numpy() * 255 + 0.5).astype(np.uint8)


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it becomes ``path`` only once the write has
    finished, so an interrupted write leaves the old file or none, never a truncated one."""
    path = Path(path)
    temporary = path.with_name(f".{path.stem}.{secrets.token_hex(4)}.tmp{path.suffix}")  # suffix: PIL's format
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_json(path: str | Path, data: dict, indent: int = 2) -> None:
    """Save ``data`` as JSON, atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(json.dumps(data, indent=indent) + "\n")


def write_png(path: str | Path, image: Tensor) -> None:
    """Save a (3, H, W) image in [0, 1]."""
    with atomic_path(path) as temporary:
        Image.fromarray(to_uint8(image)).save(temporary)


def write_gif(
    path: str | Path, brush: Brush, strokes: Tensor, width: int, height: int, background: str = "white",
    frames: int = GIF_FRAMES, seconds: float = 4.0,
) -> None:
    """An animation of the strokes appearing in order, ``frames`` frames, the last held a second;
    no strokes give one frame of the plain canvas."""
    color = torch.tensor(parse_color(background), dtype=strokes.dtype)[:, None, None]
    canvas = color.expand(3, height, width)
    ends = np.unique(np.linspace(0, len(strokes), min(frames, len(strokes)) + 1).round().astype(int))
    # Each frame kept as its palette image (1 byte a pixel) only. Fast octree palettes: Pillow's
    # default quantizer takes seconds per frame.
    palettes = [Image.fromarray(to_uint8(canvas)).quantize(256, Image.Quantize.FASTOCTREE)]
    with torch.no_grad():
        for start, end in zip(ends[:-1], ends[1:]):
            canvas = paint_canvas(brush, strokes[start:end], height, width, canvas=canvas)
            palettes.append(Image.fromarray(to_uint8(canvas)).quantize(256, Image.Quantize.FASTOCTREE))
    durations = [round(1000 * seconds / len(palettes))] * (len(palettes) - 1) + [1000]
    with atomic_path(path) as temporary:
        palettes[0].save(temporary, format="GIF", save_all=True, append_images=palettes[1:], duration=durations, loop=0)


def _hex(rgb) -> str:
    return "#" + "".join(f"{round(float(c) * 255):02x}" for c in rgb)


def _png_data_uri(gray: np.ndarray, alpha: np.ndarray | None = None) -> str:
    mode, array = ("L", gray) if alpha is None else ("LA", np.stack([gray, alpha], -1))
    buffer = io.BytesIO()
    Image.fromarray((array * 255 + 0.5).astype(np.uint8), mode).save(buffer, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()


def _oil_defs(texture: np.ndarray) -> list[str]:
    """The oil texture as an alpha mask and a shading overlay in the unit square of a stroke."""
    alpha = np.clip(texture / _OPAQUE, 0, 1)
    shade = 0.3 * (1 - texture)  # black at this opacity multiplies the colour by 0.7 + 0.3·texture
    unit = 'x="-0.5" y="-0.5" width="1" height="1" preserveAspectRatio="none"'
    return [
        '<mask id="oil-mask" maskUnits="userSpaceOnUse" x="-0.5" y="-0.5" width="1" height="1">'
        f'<image {unit} href="{_png_data_uri(alpha)}"/></mask>',
        f'<image id="oil-shade" {unit} href="{_png_data_uri(np.zeros_like(shade), shade)}"/>',
    ]


def _element(brush: str, i: int, p: np.ndarray, w: int, h: int) -> tuple[str, str]:
    """(defs, element) of stroke ``i`` with parameters ``p``."""
    sx, sy = w - 1, h - 1
    if brush in ("tape", "oilpaint"):
        cx, cy, ew, eh = p[0] * sx, p[1] * sy, max(p[2] * w, 1e-3), max(p[3] * w, 1e-3)
        frame = f'transform="translate({cx:.3f} {cy:.3f}) rotate({p[4] * 180:.3f}) scale({ew:.3f} {eh:.3f})"'
        if brush == "tape":
            return "", f'<rect x="-0.5" y="-0.5" width="1" height="1" fill="{_hex(p[5:8])}" {frame}/>'
        grad = (
            f'<linearGradient id="g{i}" gradientUnits="userSpaceOnUse" x1="-0.5" y1="0" x2="0.5" y2="0">'
            f'<stop offset="0" stop-color="{_hex(p[5:8])}"/><stop offset="1" stop-color="{_hex(p[8:11])}"/>'
            "</linearGradient>"
        )
        body = f'<rect x="-0.5" y="-0.5" width="1" height="1" fill="url(#g{i})"/><use href="#oil-shade"/>'
        return grad, f'<g {frame} mask="url(#oil-mask)">{body}</g>'
    (x0, y0, x1, y1, x2, y2) = p[:6] * np.array([sx, sy] * 3)
    if brush == "markerpen":
        d = p[6] * w / 4
        return "", (
            f'<path d="M{x0:.3f} {y0:.3f} Q{x1:.3f} {y1:.3f} {x2:.3f} {y2:.3f}" fill="none" '
            f'stroke="{_hex(p[7:10])}" stroke-width="{2 * d:.3f}" stroke-linecap="square" opacity="{p[10]:.4f}"/>'
        )
    # watercolor: the outline of discs of radius r(t) swept along B(t), filled with a C0 -> C2 gradient.
    t = np.linspace(0, 1, 33)[:, None]
    pts = (1 - t) ** 2 * [x0, y0] + 2 * (1 - t) * t * [x1, y1] + t**2 * [x2, y2]
    tangent = 2 * (1 - t) * [x1 - x0, y1 - y0] + 2 * t * [x2 - x1, y2 - y1]
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], 1) / (np.linalg.norm(tangent, axis=1, keepdims=True) + 1e-9)
    r0, r2 = p[6] * w / 4, p[7] * w / 4
    radius = r0 + (r2 - r0) * t
    outline = np.concatenate([pts + radius * normal, (pts - radius * normal)[::-1]])
    poly = " ".join(f"{a:.2f},{b:.2f}" for a, b in outline)
    grad = (
        f'<linearGradient id="g{i}" gradientUnits="userSpaceOnUse" x1="{x0:.3f}" y1="{y0:.3f}" '
        f'x2="{x2:.3f}" y2="{y2:.3f}"><stop offset="0" stop-color="{_hex(p[8:11])}"/>'
        f'<stop offset="1" stop-color="{_hex(p[11:14])}"/></linearGradient>'
    )
    body = (
        f'<polygon points="{poly}"/><circle cx="{x0:.3f}" cy="{y0:.3f}" r="{r0:.3f}"/>'
        f'<circle cx="{x2:.3f}" cy="{y2:.3f}" r="{r2:.3f}"/>'
    )
    return grad, f'<g fill="url(#g{i})" opacity="{p[14]:.4f}">{body}</g>'


def write_svg(
    path: str | Path, brush: Brush, strokes: Tensor, width: int, height: int, background: str = "white"
) -> None:
    """Each stroke as SVG elements, in painting order, on a ``width``×``height`` canvas; an oil
    brush's own texture (nsp's, or the user's) is embedded."""
    defs, body = [], []
    if brush.name == "oilpaint":
        defs += _oil_defs(brush.texture("cpu", torch.float32)[0, 0].numpy())
    for i, p in enumerate(strokes.detach().cpu().double().numpy()):
        d, e = _element(brush.name, i, p, width, height)
        defs.append(d)
        body.append(e)
    svg = "\n".join(
        [
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="-0.5 -0.5 {width} {height}">',
            "<defs>" + "".join(defs) + "</defs>",
            f'<rect x="-0.5" y="-0.5" width="{width}" height="{height}" fill="{_hex(parse_color(background))}"/>',
            *body,
            "</svg>",
        ]
    )
    with atomic_path(path) as temporary:
        temporary.write_text(svg)


def write_painting(path: str | Path, brush: Brush, strokes: Tensor, width: int, height: int, background: str) -> None:
    """Write ``path`` as PNG, SVG or GIF by its extension."""
    suffix = Path(path).suffix.lower()
    if suffix == ".png":
        with torch.no_grad():
            write_png(path, paint_canvas(brush, strokes, height, width, background))
    elif suffix == ".svg":
        write_svg(path, brush, strokes, width, height, background)
    elif suffix == ".gif":
        write_gif(path, brush, strokes, width, height, background)
    else:
        raise ValueError(f"out={path}: unknown extension '{suffix}', expected one of {', '.join(EXTENSIONS)}")
