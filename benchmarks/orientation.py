"""Do small strokes follow the picture's forms? Their long axes against the structure tensor's direction.

    python benchmarks/orientation.py STROKES.json [--image astronaut] [--share 0.5] [--coherence 0.3]

For the smallest ``--share`` of a painting's rectangle strokes (oilpaint, tape) by area, the angle between
each stroke's long axis and the direction along the forms of its photo at the stroke's centre
(:func:`nsp.painter.structure.orientation`, over a window as wide as the median such stroke is long),
where that direction is clear (coherence ≥ ``--coherence``). Prints how many lie within 22.5° (strokes
laid at random: 25 %) and the median angle (at random: 45°).
"""
from __future__ import annotations

import argparse
import math

import torch
import torch.nn.functional as F

from nsp.images import load_image
from nsp.io.strokes import load_strokes
from nsp.painter.structure import orientation, structure_tensor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("strokes")
    parser.add_argument("--image", default="astronaut", help="the photo the painting was painted from")
    parser.add_argument("--share", type=float, default=0.5)
    parser.add_argument("--coherence", type=float, default=0.3)
    args = parser.parse_args()
    painting = load_strokes(args.strokes)
    brush, x, height, width = painting.brush, painting.strokes.double(), painting.height, painting.width
    if brush.params[:5] != ("x", "y", "w", "h", "theta"):
        raise SystemExit(f"{args.strokes}: {brush.name} strokes are not rectangles; expected oilpaint or tape")
    photo = F.interpolate(load_image(args.image)[None].double(), size=(height, width), mode="area")
    w, h, theta = x[:, 2] * width, x[:, 3] * width, x[:, 4] * math.pi
    small = (w * h).argsort()[: round(args.share * len(x))]
    length = torch.maximum(w, h)[small].median()
    window = int(length) // 2 * 2 + 1
    j = structure_tensor(photo, window)[0].permute(1, 2, 0)  # (H, W, 3)
    col = (x[small, 0] * (width - 1)).round().long()
    row = (x[small, 1] * (height - 1)).round().long()
    along, coherence = orientation(j[row, col])
    axis = theta[small] + torch.where(w[small] >= h[small], 0.0, math.pi / 2)
    turn = torch.remainder(axis - along, math.pi)
    angle = torch.rad2deg(torch.minimum(turn, math.pi - turn))[coherence >= args.coherence]  # in [0°, 90°]
    within = float((angle <= 22.5).double().mean()) if len(angle) else float("nan")
    print(f"{args.strokes}: {len(small)} smallest strokes (median {float(length):.1f} px long, window {window} px), "
          f"{len(angle)} where the forms have a direction (coherence ≥ {args.coherence}): {within:.0%} within 22.5° "
          f"of it (random: 25 %), median {float(angle.median()):.1f}° (random: 45°)")


if __name__ == "__main__":
    main()
