"""``python -m nsp.render strokes=PATH [brush=B] size=PX [canvas=COLOUR] out=PATH``: re-render a
stroke file (nsp JSON, or a reference .npz with ``brush=``) as PNG, SVG or GIF."""
from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import hydra
from hydra.core.config_store import ConfigStore
from omegaconf import MISSING, DictConfig
from omegaconf.errors import MissingMandatoryValue

from nsp.config import BrushConfig
from nsp.engine.canvas import parse_color
from nsp.io.export import EXTENSIONS, write_painting
from nsp.io.strokes import load_strokes


@dataclass
class RenderConfig:
    strokes: str = MISSING
    out: str = MISSING
    size: int = 512
    canvas: Optional[str] = None  # None: the stroke file's own background
    brush: Optional[BrushConfig] = None  # needed for reference .npz files only


ConfigStore.instance().store(name="render_schema", node=RenderConfig)


def render(cfg: DictConfig) -> Path:
    """Render ``cfg.strokes`` to ``cfg.out``; returns the written path."""
    out = Path(cfg.out)
    if out.suffix.lower() not in EXTENSIONS:
        raise ValueError(f"out={cfg.out}: unknown extension '{out.suffix}', expected one of {', '.join(EXTENSIONS)}")
    if cfg.size <= 0:
        raise ValueError(f"size={cfg.size}: expected a positive number of pixels")
    brush = cfg.brush.name if cfg.get("brush") else None
    painting = load_strokes(cfg.strokes, brush=brush, size=cfg.size)
    background = cfg.canvas if cfg.canvas is not None else painting.background
    parse_color(background)
    height, width = painting.size(cfg.size)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_painting(out, painting.brush, painting.strokes, width, height, background)
    return out


@hydra.main(config_path="../../conf/render", config_name="render", version_base="1.3")
def main(cfg: DictConfig) -> None:
    try:
        print(f"wrote {render(cfg)}")
    except MissingMandatoryValue as err:
        print(f"error: {err.full_key}= is required (strokes=PATH out=PATH.png|.svg|.gif)", file=sys.stderr)
        sys.exit(2)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
