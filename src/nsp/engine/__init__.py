"""The vector engine: batched antialiased rasterization, its soft mode, compositing."""
from nsp.engine.canvas import paint_canvas
from nsp.engine.raster import composite, render

__all__ = ["composite", "paint_canvas", "render"]
