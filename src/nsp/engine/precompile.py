"""A job of ``python -m nsp.engine``: compile the kernels a painting with one brush uses, by
rendering with them. It lives apart from the command because the command's worker processes are
spawned, and a spawned process can import a job from a module, not from a package's ``__main__``."""
from __future__ import annotations

import time

import torch

from nsp.brushes import BRUSHES
from nsp.engine import fused
from nsp.engine.raster import render


def compile_for_painting(name: str, width: int | None = None) -> str:
    """Compile the kernels of any canvas size a painting with the brush ``name`` uses
    (:func:`~nsp.engine.fused.painting_kernels`): without ``width``, by a soft render and its backward
    and a render of its plain paint; with ``width``, by a render of its paint as drawn on canvases
    ``width`` px wide (:meth:`~nsp.brushes.Brush.sized`: oil's bristle scales). Kernels already on disk
    are loaded and checked, not compiled again. What happened, in a line."""
    brush, start = BRUSHES[name], time.perf_counter()
    cpu, kernels = torch.device("cpu"), fused.painting_kernels(name, None if width is None else (width,))
    there = all(fused.package(stage, shaded, consts, cpu).exists() for stage, shaded, consts in kernels)
    x, what = brush.sample(16, torch.Generator().manual_seed(0)), name if width is None else f"{name} at {width} px"
    try:
        if width is None:
            strokes = x.clone().requires_grad_()
            fg, alpha = render(brush, strokes, 32, softness=brush.softness, compile=True)
            (fg.sum() + alpha.sum()).backward()
        with torch.no_grad():
            render(brush.plain() if width is None else brush.sized(width), x, 32, compile=True)
    except Exception as err:  # painting still works, eagerly
        message = (str(err).strip() or "no message").splitlines()[0][:300]
        return f"{what}: not compiled ({type(err).__name__}: {message}); it is drawn eagerly"
    for stage, shaded, consts in kernels:
        if (why := fused.why_without(stage, shaded, consts, cpu)) is not None:
            return f"{what}: not compiled ({why}); it is drawn eagerly"
    return f"{what}: already compiled (checked)" if there else f"{what}: {time.perf_counter() - start:.0f} s"
