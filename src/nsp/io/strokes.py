"""nsp's stroke file (versioned JSON) and import of the reference implementation's ``.npz``."""
from __future__ import annotations

import json
import math
import re
import zipfile
import zlib
from dataclasses import dataclass
from itertools import chain
from operator import itemgetter
from pathlib import Path

import numpy as np
import orjson
import torch
from torch import Tensor

from nsp.brushes import BRUSHES, Brush, get_brush
from nsp.brushes.registry import GLAZING
from nsp.brushes.texture import EMBEDDED, embedded
from nsp.colors import parse_color
from nsp.config import MAX_PAINTS
from nsp.errors import BadInput
from nsp.files import write_json
from nsp.text import shown

FORMAT, VERSION = "nsp-strokes", 1
NPZ_ARRAYS = ("x_ctt", "x_color", "x_alpha")  # the reference's shape-and-position, colour and alpha arrays
NPZ_MAX_VALUES = 50_000_000  # per array: a million strokes of the widest brush, 400 MB as float64
MAX_CANVAS = 10**9  # pixels a side: the canvas sets only the aspect, but a larger one is no painting's
NPY_HEADERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}


class StrokeFileError(BadInput):
    """A stroke file that cannot be read; the message names the file and what is expected."""


def _check(ok: bool, message: str) -> None:
    """Raise :class:`StrokeFileError` with ``message`` unless ``ok``."""
    if not ok:
        raise StrokeFileError(message)


@dataclass
class StrokeFile:
    """A painting: an ordered list of strokes of one brush on a plain canvas."""

    brush: Brush  # its oil texture (brush.texture=PATH) included
    strokes: Tensor  # (N, d) parameters in [0, 1], painted first to last
    height: int = 512  # the canvas the strokes were made for: only its aspect ratio matters
    width: int = 512
    background: str = "white"  # black, white or #rrggbb
    paints: list[str] | None = None  # the paints (#rrggbb) it was laid in, layer by layer (``paints=``); None: free colours

    def size(self, long_side: int) -> tuple[int, int]:
        """(height, width) in pixels for a render whose long side is ``long_side``."""
        scale = long_side / max(self.width, self.height)
        return max(1, round(self.height * scale)), max(1, round(self.width * scale))


def save_strokes(path: str | Path, painting: StrokeFile) -> None:
    """Write ``painting`` as nsp JSON; :func:`load_strokes` reads back exactly the same values."""
    brush, width, height = painting.brush, painting.width, painting.height
    data = {
        "format": FORMAT, "version": VERSION, "brush": brush.name, "params": list(brush.params),
        "canvas": {"width": width, "height": height, "aspect": width / height, "background": painting.background},
        "seed": brush.seed,  # with each stroke's index, what its bristles are drawn from
        # float() of a float32 is exact, and JSON keeps every digit of a Python float.
        "strokes": [dict(zip(brush.params, map(float, row))) for row in painting.strokes.tolist()],
    }
    if not getattr(brush, "impasto", True):
        data["impasto"] = False
    if brush.name in GLAZING:
        data["glaze"] = brush.glaze  # how its strokes blend (a file without it was painted before glazes: 0)
    if painting.paints is not None:
        data["paints"] = list(painting.paints)
    if brush.texture_path is not None:
        data["texture"] = embedded(brush.texture_path)  # the image itself: a stroke file names no file to read
    write_json(path, data, indent=1)


def load_strokes(path: str | Path, brush: str | None = None, size: int = 512) -> StrokeFile:
    """Read an nsp ``.json`` stroke file, or a reference ``.npz`` (then ``brush`` is required and
    ``size`` is the canvas width its pixel conventions are converted at)."""
    path = Path(path)
    _check(path.is_file(), f"strokes={path}: no such file")
    if path.suffix == ".npz":
        _check(brush is not None, f"strokes={path} is a reference .npz: say which brush with brush=")
        return _load_npz(path, brush, size)
    _check(path.suffix == ".json", f"strokes={path}: expected an nsp .json or a reference .npz file")
    return _load_json(path, brush)


def _load_json(path: Path, brush: str | None) -> StrokeFile:
    text = path.read_bytes()
    try:
        data = orjson.loads(text)  # 5× faster than json on thousands of strokes
    except orjson.JSONDecodeError:  # what only json reads (NaN, Infinity: refused below, by name), or its message
        try:
            data = json.loads(text)
        except (ValueError, RecursionError) as err:  # also nesting too deep, an integer of thousands of digits
            reason = "nested too deep" if isinstance(err, RecursionError) else str(err)[:120]
            raise StrokeFileError(f"strokes={path} is not valid JSON ({reason})") from None
    _check(isinstance(data, dict) and data.get("format") == FORMAT,
           f"strokes={path} is not an nsp stroke file (expected a JSON object with format '{FORMAT}')")
    _check(data.get("version") == VERSION,
           f"strokes={path} has version {shown(data.get('version'))}; this nsp reads {VERSION}")
    name = data.get("brush")
    _check(isinstance(name, str) and name in BRUSHES,
           f"strokes={path}: unknown brush {shown(name)}, expected one of: {', '.join(BRUSHES)}")
    params = data.get("params") if isinstance(data.get("params"), list) else None
    spec = get_brush(name, params=params)
    _check(brush is None or brush == spec.name, f"strokes={path} holds {spec.name} strokes, not brush={brush}")
    canvas = data.get("canvas")
    _check(isinstance(canvas, dict) and all(_is_size(canvas.get(k)) for k in ("width", "height"))
           and isinstance(canvas.get("background"), str),
           f'strokes={path} is malformed: expected "canvas": '
           '{"width": pixels, "height": pixels, "background": colour}')
    _check(max(canvas["width"], canvas["height"]) <= MAX_CANVAS,
           f"strokes={path}: its canvas (width {_shown_size(canvas['width'])}, height {_shown_size(canvas['height'])}) "
           f"is no painting's; expected sides from 1 to {MAX_CANVAS} pixels")
    try:
        parse_color(canvas["background"])
    except ValueError:
        raise StrokeFileError(f"strokes={path}: its background {shown(canvas['background'])} is not a colour; "
                              "expected black, white or #rrggbb") from None
    strokes, keys = data.get("strokes"), ", ".join(spec.params)
    _check(isinstance(strokes, list) and all(isinstance(s, dict) for s in strokes),
           f'strokes={path} is malformed: expected "strokes": a list of objects with {keys}')
    try:
        rows = list(map(itemgetter(*spec.params), strokes))
    except KeyError:
        rows = None
    if rows is None or not set(map(type, chain.from_iterable(rows))) <= {int, float}:  # bool, None, str: not numbers
        lacking = sum(not all(_is_number(stroke.get(key)) for key in spec.params) for stroke in strokes)
        raise StrokeFileError(f"strokes={path}: {lacking} of {len(strokes)} strokes lack a number for one of {keys}")
    try:
        with np.errstate(over="ignore"):  # a float past float32's range becomes inf, refused by name below
            values = torch.from_numpy(np.array(rows, dtype=np.float32).reshape(-1, spec.d))
    except OverflowError:  # an integer past any float
        raise StrokeFileError(f"strokes={path}: a stroke parameter is far outside [0, 1]") from None
    _check_range(path, values, spec.params)
    texture, seed, impasto = data.get("texture"), data.get("seed", 0), data.get("impasto", True)
    glaze = data.get("glaze", 0.0 if spec.name in GLAZING else None)
    _check(texture is None or (isinstance(texture, str) and texture.startswith(EMBEDDED)),
           f'strokes={path}: its "texture" is not an embedded image ({EMBEDDED}…); '
           "a stroke file carries its texture, it names no file to read")
    _check(isinstance(seed, int) and not isinstance(seed, bool) and abs(seed) < 2**63,
           f'strokes={path}: its "seed" {str(seed)[:40]!r} is not an integer')
    _check(isinstance(impasto, bool), f'strokes={path}: its "impasto" {str(impasto)[:40]!r} is not true or false')
    try:
        spec = get_brush(spec.name, texture, params, seed=seed, impasto=impasto, glaze=glaze)
    except ValueError as error:
        raise StrokeFileError(f"strokes={path}: its brush cannot be used: {error}") from None
    paints = data.get("paints")
    _check(paints is None or (isinstance(paints, list) and 1 <= len(paints) <= MAX_PAINTS and all(
        isinstance(paint, str) and re.fullmatch(r"#[0-9a-fA-F]{6}", paint) for paint in paints)),
           f'strokes={path}: its "paints" {str(paints)[:60]} are not 1 to {MAX_PAINTS} colours #rrggbb')
    return StrokeFile(spec, values, canvas["height"], canvas["width"], canvas["background"], paints)


def _shown_size(value: int) -> str:
    """A canvas side as a message quotes it: its digits, or their count past 12 (JSON's are at most 4300)."""
    return str(value) if value < 10**12 else f"a {len(str(value))}-digit number"


def _is_size(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value > 0


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _check_range(path: Path, strokes: Tensor, params: tuple[str, ...]) -> None:
    """Refuse strokes (N, d) with a parameter that is not a finite number in [0, 1]."""
    good = (strokes >= 0) & (strokes <= 1)  # NaN fails both comparisons
    bad = ~good.all(1)
    if bad.any():
        row = int(bad.nonzero()[0])
        col = int((~good[row]).nonzero()[0])
        raise StrokeFileError(f"strokes={path}: {int(bad.sum())} of {len(strokes)} strokes have a parameter that is "
                              f"not a finite number in [0, 1], got {strokes[row, col].item():g} "
                              f"({params[col]} of stroke {row})")


def _read_npz(path: Path) -> list[np.ndarray]:
    """The reference's three arrays (float64), each (N, k) or (1, N, k), read only after their headers
    say they hold plain numbers and no more values than their bytes in the file."""
    arrays = []
    try:
        with zipfile.ZipFile(path) as archive:
            for key in NPZ_ARRAYS:
                _check(f"{key}.npy" in archive.namelist(),
                       f"strokes={path} lacks array {key!r}; expected {', '.join(NPZ_ARRAYS)}")
                info = archive.getinfo(f"{key}.npy")
                with archive.open(info) as member:
                    version = np.lib.format.read_magic(member)
                    if version not in NPY_HEADERS:
                        raise ValueError(f"npy format version {version} in {key}")
                    shape, _, dtype = NPY_HEADERS[version](member)
                    count = math.prod(shape)
                    _check(dtype.kind in "fiu" and dtype.fields is None and 2 <= len(shape) <= 3 and shape[-1] >= 1,
                           f"strokes={path}: {key} is {dtype} {list(shape)}; "
                           "expected numbers, shaped [1, N, k] or [N, k]")
                    _check(count <= NPZ_MAX_VALUES and count * dtype.itemsize <= info.file_size,
                           f"strokes={path}: {key} claims {count} values, more than its bytes hold "
                           f"or {NPZ_MAX_VALUES} (a damaged file?)")
                with archive.open(info) as member:  # from its start: read_array reads the header itself
                    arrays.append(np.lib.format.read_array(member, allow_pickle=False))
    except StrokeFileError:
        raise
    # NotImplementedError, RuntimeError: zip methods, versions and encryption zipfile cannot read
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError, RuntimeError) as err:
        reason = str(err).strip().splitlines()[0][:100] if str(err).strip() else type(err).__name__
        raise StrokeFileError(f"strokes={path} is not a readable .npz ({reason})") from None
    return [np.asarray(a, dtype=np.float64) for a in arrays]


def _load_npz(path: Path, brush: str, size: int) -> StrokeFile:
    spec = get_brush(brush, glaze=0.0 if brush in GLAZING else None)  # the reference's strokes cover what is under them
    ctt, color, alpha = (a.reshape(-1, a.shape[-1]) if a.ndim == 3 else a for a in _read_npz(path))
    n_ctt, n_color = spec.reference
    _check(ctt.shape[1:] == (n_ctt,) and color.shape[1:] == (n_color,) and len(ctt) == len(color) == alpha.size,
           f"strokes={path}: x_ctt {ctt.shape} / x_color {color.shape} / x_alpha {alpha.shape} "
           f"do not fit brush={brush} (expected [1, N, {n_ctt}], [1, N, {n_color}] and [1, N, 1])")
    alpha = alpha.reshape(-1, 1)
    bad = ~np.isfinite(np.concatenate([ctt, color, alpha], 1)).all(1)
    if bad.any():
        raise StrokeFileError(f"strokes={path}: {bad.sum()} of {len(ctt)} strokes hold NaN or infinite values "
                              f"(first: stroke {bad.nonzero()[0][0]}); expected finite numbers")
    for name, values in (("x_ctt", ctt), ("x_color", color), ("x_alpha", alpha)):
        outside = (values < 0) | (values > 1)
        if outside.any():
            row, col = np.argwhere(outside)[0]
            raise StrokeFileError(f"strokes={path}: {outside.any(1).sum()} of {len(ctt)} strokes have a value outside "
                                  f"[0, 1] in {name}, got {values[row, col]:g} (stroke {row}, column {col}); "
                                  "the reference's parameters lie in [0, 1]")
    painted_with, strokes = spec.from_reference(ctt, color, alpha, size)
    return StrokeFile(painted_with, torch.tensor(strokes, dtype=torch.float32), size, size, "white")
