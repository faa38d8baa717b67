"""The four brushes of the paper (§3.1, appendix tables): each module holds one brush's parameter
spec, rendering (signed distance, shading) and formats (SVG element, reference .npz conversion);
:mod:`~nsp.brushes.registry` names them all."""
from nsp.brushes.base import Brush, Pixels
from nsp.brushes.registry import BRUSHES, VARIANTS, get_brush

__all__ = ["BRUSHES", "VARIANTS", "Brush", "Pixels", "get_brush"]
