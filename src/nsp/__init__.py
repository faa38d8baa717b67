"""nsp — stroke-based painting: photographs in, paintings of vector brush strokes out."""

__version__ = "0.1.0"
