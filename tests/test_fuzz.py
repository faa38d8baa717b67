"""Stroke files mutated at random (seeded): every one is refused in one line naming the file, or read
and rendered to a canvas of finite colours in [0, 1]. Nothing else: no traceback, hang or huge
allocation, whatever bytes or values a shared file holds."""
from __future__ import annotations

import io
import json
import os
import random
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

from nsp.brushes import BRUSHES
from nsp.engine import paint_canvas
from nsp.io.strokes import StrokeFile, StrokeFileError, load_strokes, save_strokes

# Per run of the suite a few hundred files (seconds); a longer campaign: NSP_FUZZ_SCALE=50 python -m pytest tests/test_fuzz.py
SCALE = int(os.environ.get("NSP_FUZZ_SCALE", 1))
JSON_CASES = 240 * SCALE
NPZ_CASES = 120 * SCALE
ODD_VALUES = [None, True, False, 0, -1, 1, 0.5, -1e-30, 1e308, 2**64, -(2**70), 10**30, "", "x", "0.5", "NaN", [], {},
              [0.5] * 3, {"x": 0.5}, "data:image/png;base64,AAAA", "#12345", "black", "/etc/passwd", "../secret.png",
              "two\nlines", "y" * 1000]


def read_or_refuse(path: Path, brush: str | None = None) -> str:
    """Load ``path`` and render it small; 'refused' or 'rendered', failing on anything else."""
    try:
        painting = load_strokes(path, brush, size=64)
    except StrokeFileError as error:
        message = str(error)
        assert "\n" not in message and message.startswith(f"strokes={path}") and len(message) < 400, message
        return "refused"
    assert painting.strokes.ndim == 2 and painting.strokes.shape[1] == painting.brush.d
    assert bool(((painting.strokes >= 0) & (painting.strokes <= 1)).all())
    height, width = painting.size(32)
    canvas = paint_canvas(painting.brush, painting.strokes[:64], height, width, painting.background, compile=False)
    assert canvas.shape == (3, height, width) and bool(torch.isfinite(canvas).all())
    assert float(canvas.min()) >= 0 and float(canvas.max()) <= 1
    return "rendered"


def nodes(tree, path=()):
    """Every (path, value) in a JSON tree, the root included."""
    yield path, tree
    children = tree.items() if isinstance(tree, dict) else enumerate(tree) if isinstance(tree, list) else ()
    for key, value in children:
        yield from nodes(value, (*path, key))


def set_at(tree, path, value):
    if not path:
        return value
    parent = tree
    for key in path[:-1]:
        parent = parent[key]
    parent[path[-1]] = value
    return tree


def mutate_json(text: str, rng: random.Random) -> bytes:
    """One of: a node replaced by an odd value, a key dropped, a key added, bytes flipped, cut or spliced."""
    kind = rng.randrange(6)
    if kind < 3:
        tree = json.loads(text)
        path, value = rng.choice(list(nodes(tree)))
        if kind == 0 or not path:
            tree = set_at(tree, path, rng.choice(ODD_VALUES))
        elif kind == 1 and isinstance(value, dict) and value:
            del value[rng.choice(list(value))]
        elif isinstance(value, dict):
            value[rng.choice(["x", "brush", "texture", "seed", "impasto", "params", "canvas", "version"])] = rng.choice(ODD_VALUES)
        else:
            tree = set_at(tree, path, rng.choice(ODD_VALUES))
        return json.dumps(tree).encode()
    data = bytearray(text.encode())
    if kind == 3:
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] = rng.randrange(256)
    elif kind == 4:
        data = data[: rng.randrange(len(data))]
    else:
        at = rng.randrange(len(data))
        data[at:at] = rng.choice([b"NaN", b"Infinity", b"-", b"1e999", b"]", b"{", b'"', b"\xff\xfe", b"9" * 40])
    return bytes(data)


@pytest.fixture(scope="module")
def stroke_files(tmp_path_factory) -> dict[str, str]:
    """A small saved painting of every brush, as text."""
    tmp, texts = tmp_path_factory.mktemp("originals"), {}
    for name, brush in BRUSHES.items():
        strokes = torch.rand(6, brush.d, generator=torch.Generator().manual_seed(len(name)))
        save_strokes(tmp / f"{name}.json", StrokeFile(brush, strokes, 48, 64))
        texts[name] = (tmp / f"{name}.json").read_text()
    return texts


def test_mutated_stroke_files_are_refused_in_one_line_or_render(stroke_files, tmp_path):
    rng, outcomes = random.Random(0), []
    for case in range(JSON_CASES):
        path = tmp_path / f"{case}.json"
        path.write_bytes(mutate_json(stroke_files[rng.choice(list(stroke_files))], rng))
        outcomes.append(read_or_refuse(path))
    assert 0.3 < outcomes.count("refused") / len(outcomes) < 0.95, outcomes  # both kinds of outcome are exercised


REFERENCE_WIDTHS = {"oilpaint": (5, 3), "watercolor": (8, 6), "markerpen": (8, 3), "tape": (5, 3)}


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    out = io.BytesIO()
    np.savez(out, **arrays)
    return out.getvalue()


def mutate_npz(brush: str, rng: np.random.Generator) -> bytes:
    """A reference file of ``brush`` with one fault: bytes flipped or cut, an array missing, of
    another shape or dtype, holding NaN, infinities or values outside [0, 1], or a lying header."""
    n, (c, k) = int(rng.integers(0, 6)), REFERENCE_WIDTHS[brush]
    arrays = {"x_ctt": rng.random((1, n, c)), "x_color": rng.random((1, n, k)), "x_alpha": np.ones((1, n, 1))}
    key = str(rng.choice(list(arrays)))
    kind = int(rng.integers(9))
    if kind == 0:
        data = bytearray(npz_bytes(arrays))
        for at in rng.integers(0, len(data), int(rng.integers(1, 12))):
            data[at] = int(rng.integers(256))
        return bytes(data)
    if kind == 1:
        data = npz_bytes(arrays)
        return data[: int(rng.integers(len(data)))]
    if kind == 2:
        del arrays[key]
    elif kind == 3:
        arrays[key] = rng.random(tuple(int(d) for d in rng.integers(0, 4, int(rng.integers(0, 5)))))
    elif kind == 4:
        dtype = rng.choice(["int8", "uint16", "bool", "complex64", "float16", "<U3"])
        arrays[key] = arrays[key].astype(dtype) if dtype != "<U3" else arrays[key].astype(str)
    elif kind == 5 and n:
        arrays[key].flat[int(rng.integers(arrays[key].size))] = rng.choice([np.nan, np.inf, -np.inf, -5, 1e300, 1.0001])
    elif kind == 6:
        arrays[key] = np.zeros(arrays[key].shape, dtype=[("a", "f4"), ("b", "i2")])
    elif kind == 7:  # a header that claims billions of values over a few bytes
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (1, 10**9, c)})
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w") as archive:
            for name, array in arrays.items():
                body = io.BytesIO()
                np.save(body, array)
                archive.writestr(f"{name}.npy", header.getvalue() + b"\0" * 64 if name == key else body.getvalue())
        return out.getvalue()
    else:
        arrays[key] = arrays[key][..., : int(rng.integers(0, arrays[key].shape[-1] + 1))]
    return npz_bytes(arrays)


def test_mutated_reference_files_are_refused_in_one_line_or_render(tmp_path):
    rng, outcomes = np.random.default_rng(0), []
    for case in range(NPZ_CASES):
        brush = str(rng.choice(list(REFERENCE_WIDTHS)))
        path = tmp_path / f"{case}.npz"
        path.write_bytes(mutate_npz(brush, rng))
        outcomes.append(read_or_refuse(path, brush))
    assert 0.5 < outcomes.count("refused") / len(outcomes) < 1, outcomes
