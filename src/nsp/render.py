"""``python -m nsp.render strokes=PATH [brush=B] size=PX [background=COLOUR] out=PATH``: re-render a
stroke file (nsp JSON, or a reference .npz with ``brush=``) as PNG, SVG or GIF. The engine (torch)
is imported only once the command line has been read."""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Union

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING, DictConfig, OmegaConf

from nsp.cli import command, fail, program
from nsp.config import PlotConfig, compile_choice
from nsp.errors import BadInput
from nsp.signals import numpy_before_torch

TEXT = ("strokes", "out", "background")  # free text: paths, ``#rrggbb``


@dataclass
class RenderConfig:
    strokes: str = MISSING
    out: str = MISSING
    size: int = 512
    background: Optional[str] = None  # None: the stroke file's own background
    # the compiled kernels: true, compiled first where missing; auto: those this machine has (nsp.engine.fused.choose)
    compile: Union[bool, str, None] = "auto"
    device: str = "cpu"  # cpu, cuda, cuda:N or auto
    brush: Optional[Any] = None  # a ``brush`` group option (nsp.config.BrushConfig); for reference .npz files only
    plot: PlotConfig = field(default_factory=PlotConfig)  # out=….hpgl or ….gcode: a painting laid in paints, for a machine


ConfigStore.instance().store(name="render_schema", node=RenderConfig)


def render(cfg: DictConfig) -> Path:
    """Render ``cfg.strokes`` to ``cfg.out``; returns the written path. The file appears whole or
    not at all: an error or an interrupt leaves no partial file."""
    numpy_before_torch()
    from nsp.colors import parse_color
    from nsp.engine.device import resolve_device
    from nsp.engine.memory import check_render, check_side
    from nsp.io.export import EXTENSIONS, frame_ends, write_painting
    from nsp.io.machine import MACHINE, write_machine
    from nsp.io.strokes import load_strokes

    out = Path(cfg.out)
    suffix = out.suffix.lower()
    if out.is_dir():
        raise BadInput(f"out={cfg.out} is a folder; expected a file path ending in {', '.join(EXTENSIONS + MACHINE)}")
    if suffix not in EXTENSIONS + MACHINE:
        raise BadInput(f"out={cfg.out}: unknown extension '{out.suffix}', expected one of {', '.join(EXTENSIONS + MACHINE)}")
    check_side(cfg.size)
    compile = compile_choice(cfg.compile, "compile")
    device = resolve_device(cfg.device)
    name = cfg.brush.name if cfg.get("brush") else None  # reference .npz files only
    painting = load_strokes(cfg.strokes, brush=name, size=cfg.size)
    background = cfg.background if cfg.background is not None else painting.background
    parse_color(background)
    height, width = painting.size(cfg.size)
    brush = painting.brush
    check_render(brush, painting.strokes, height, width, suffix, frames=len(frame_ends(len(painting.strokes))) if suffix == ".gif" else 0)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise BadInput(f"out={cfg.out}: cannot make its folder {out.parent} ({err.strerror or err})") from None
    if suffix in MACHINE and painting.paints is None:
        raise BadInput(f"out={cfg.out}: strokes={cfg.strokes} has no paints; a machine paints with some "
                       "(python -m nsp.paint … paints=6, or paints=[#rrggbb,…])")
    try:
        if suffix in MACHINE:
            write_machine(out, brush, painting.strokes, painting.paints, height, width, cfg.plot)
        else:
            write_painting(out, brush, painting.strokes.to(device), height, width, background, compile)
    except OSError as err:
        raise BadInput(f"out={cfg.out}: cannot write it ({err.strerror or err})") from None
    return out


def main(cfg: DictConfig) -> None:
    start = time.perf_counter()
    try:
        for key in ("strokes", "out"):
            if OmegaConf.is_missing(cfg, key):
                raise BadInput(f"{key}= is required (strokes=PATH out=PATH.png|.svg|.gif|.hpgl|.gcode)")
        print(f"rendering {cfg.strokes} as {cfg.out}…", flush=True)  # the first line, before the engine loads
        out = render(cfg)
        print(f"wrote {out} in {time.perf_counter() - start:.1f} s")
    except BadInput as err:
        fail(str(err))
    except KeyboardInterrupt:
        print(f"interrupted: nothing written to {cfg.out}", file=sys.stderr)
        raise


def schema() -> RenderConfig:
    """Every key a render config can have (registers the ``brush`` group)."""
    from nsp.config import BrushConfig

    return RenderConfig(brush=BrushConfig(MISSING))


def cli() -> None:
    """The command line: ``python -m nsp.render``."""
    command("render", main, schema, text=TEXT)


def run() -> None:
    """``python -m nsp.render`` and ``nsp-render``: :func:`cli` as the whole process (:func:`nsp.cli.program`)."""
    program(cli)


if __name__ == "__main__":
    run()
