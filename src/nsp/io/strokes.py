"""nsp's stroke file (versioned JSON) and import of the reference implementation's ``.npz``."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from nsp.brushes import get_brush
from nsp.engine.canvas import parse_color

FORMAT, VERSION = "nsp-strokes", 1


class StrokeFileError(ValueError):
    """A stroke file that cannot be read; the message names the file and what is expected."""


@dataclass
class StrokeFile:
    """A painting: an ordered list of strokes of one brush on a plain canvas.

    Attributes:
        brush: brush name.
        strokes: (N, d) parameters in [0, 1], painted first to last.
        width, height: the canvas size the strokes were made for; only the aspect ratio matters,
            strokes render at any size.
        background: canvas colour, ``black``, ``white`` or ``#rrggbb``.
    """

    brush: str
    strokes: Tensor
    width: int = 512
    height: int = 512
    background: str = "white"

    def size(self, long_side: int) -> tuple[int, int]:
        """(height, width) in pixels for a render whose long side is ``long_side``."""
        scale = long_side / max(self.width, self.height)
        return max(1, round(self.height * scale)), max(1, round(self.width * scale))


def save_strokes(path: str | Path, painting: StrokeFile) -> None:
    """Write ``painting`` as nsp JSON; :func:`load_strokes` reads back exactly the same values."""
    brush = get_brush(painting.brush)
    data = {
        "format": FORMAT,
        "version": VERSION,
        "brush": brush.name,
        "params": list(brush.params),
        "canvas": {
            "width": painting.width,
            "height": painting.height,
            "aspect": painting.width / painting.height,
            "background": painting.background,
        },
        # float() of a float32 is exact, and JSON keeps every digit of a Python float.
        "strokes": [dict(zip(brush.params, map(float, row))) for row in painting.strokes.tolist()],
    }
    Path(path).write_text(json.dumps(data, indent=1))


def load_strokes(path: str | Path, brush: str | None = None, size: int = 512) -> StrokeFile:
    """Read an nsp ``.json`` stroke file, or a reference ``.npz`` (then ``brush`` is required and
    ``size`` is the canvas width its pixel conventions are converted at)."""
    path = Path(path)
    if not path.is_file():
        raise StrokeFileError(f"strokes={path}: no such file")
    if path.suffix == ".npz":
        if brush is None:
            raise StrokeFileError(f"strokes={path} is a reference .npz: say which brush with brush=")
        return _load_npz(path, brush, size)
    if path.suffix != ".json":
        raise StrokeFileError(f"strokes={path}: expected an nsp .json or a reference .npz file")
    return _load_json(path, brush)


def _load_json(path: Path, brush: str | None) -> StrokeFile:
    try:
        data = json.loads(path.read_text())
        if data.get("format") != FORMAT:
            raise StrokeFileError(f"strokes={path} is not an nsp stroke file (no format '{FORMAT}')")
        if data.get("version") != VERSION:
            raise StrokeFileError(f"strokes={path} has version {data.get('version')}; this nsp reads {VERSION}")
        spec = get_brush(data["brush"])
        if brush is not None and brush != spec.name:
            raise StrokeFileError(f"strokes={path} holds {spec.name} strokes, not brush={brush}")
        rows = [[stroke[name] for name in spec.params] for stroke in data["strokes"]]
        canvas = data["canvas"]
        painting = StrokeFile(
            spec.name,
            torch.tensor(rows, dtype=torch.float32).reshape(-1, spec.d),
            int(canvas["width"]),
            int(canvas["height"]),
            str(canvas["background"]),
        )
    except StrokeFileError:
        raise
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise StrokeFileError(f"strokes={path} is not valid JSON ({err})") from None
    except (KeyError, TypeError, ValueError) as err:
        raise StrokeFileError(f"strokes={path} is malformed ({type(err).__name__}: {err})") from None
    parse_color(painting.background)
    spec.validate(painting.strokes)
    return painting


# Reference conventions (SPEC §2) -> nsp's resolution-independent ones, at canvas width W.
def _reference_to_nsp(brush: str, ctt: np.ndarray, color: np.ndarray, alpha: np.ndarray, w: int) -> np.ndarray:
    if brush in ("watercolor", "markerpen"):
        x0, y0, x1, y1, x2, y2 = ctt[:, :6].T
        shape = [x0, y0, x0 + (x2 - x0) * x1, y0 + (y2 - y0) * y1, x2, y2]  # relative P1 -> absolute
        radii = ctt[:, 6:8] if brush == "watercolor" else ctt[:, 6:7]  # marker pen's 2nd radius unused
        shape += list(((1 + radii * w / 4) / (w / 4)).T)  # radius 1 + r·W/4 px -> r'·W/4
        parts = [np.stack(shape, 1), color, alpha]
    elif brush == "tape":
        sizes = 2 * (1 + ctt[:, 2:4] * w / 4) / w  # half extents 1 + w·W/4 px -> full extent / W
        parts = [ctt[:, :2], sizes, ctt[:, 4:5], color]
    else:  # oilpaint
        sizes = (1 + ctt[:, 2:4] * w) / w  # extents 1 + w·W px -> fraction of W
        parts = [ctt[:, :2], sizes, ctt[:, 4:5], color]
    return np.clip(np.concatenate(parts, 1), 0, 1)


_REFERENCE_DIMS = {"watercolor": (8, 6), "markerpen": (8, 3), "tape": (5, 3), "oilpaint": (5, 6)}


def _load_npz(path: Path, brush: str, size: int) -> StrokeFile:
    spec = get_brush(brush)
    try:
        with np.load(path) as data:
            arrays = [np.asarray(data[k], dtype=np.float64) for k in ("x_ctt", "x_color", "x_alpha")]
    except KeyError as err:
        raise StrokeFileError(f"strokes={path} lacks array {err}; expected x_ctt, x_color, x_alpha") from None
    except (OSError, ValueError) as err:
        raise StrokeFileError(f"strokes={path} is not a readable .npz ({err})") from None
    ctt, color, alpha = (a.reshape(-1, a.shape[-1]) if a.ndim == 3 else a for a in arrays)
    n_ctt, n_color = _REFERENCE_DIMS[spec.name]
    if ctt.shape[1:] != (n_ctt,) or color.shape[1:] != (n_color,) or len(ctt) != len(color):
        raise StrokeFileError(
            f"strokes={path}: x_ctt {ctt.shape} / x_color {color.shape} do not fit brush={brush} "
            f"(expected [1, N, {n_ctt}] and [1, N, {n_color}])"
        )
    strokes = _reference_to_nsp(spec.name, ctt, color, alpha.reshape(len(ctt), -1)[:, :1], size)
    return StrokeFile(spec.name, torch.tensor(strokes, dtype=torch.float32), size, size, "white")
