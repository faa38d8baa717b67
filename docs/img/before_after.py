"""Paintings of the astronaut side by side with the photo: the whole painting above, the face from its
1024-px final.png below, each ``--cell`` pixels wide.

    python docs/img/before_after.py OUT.png LABEL=final.png [LABEL=final.png ...] [--cell 256]

docs/img/demo.png, the demo (the README's picture):

    python -m nsp.paint hydra.run.dir=/tmp/sp/demo
    python docs/img/before_after.py docs/img/demo.png "500 oil strokes=/tmp/sp/demo/final.png" --cell 320  # the face at 1:1

docs/img/painter_faces.png, the demo without and with a level of its own for the face:

    python -m nsp.paint schedule.face_share=0 hydra.run.dir=/tmp/sp/noface
    python -m nsp.paint hydra.run.dir=/tmp/sp/face
    python docs/img/before_after.py docs/img/painter_faces.png "no face level=/tmp/sp/noface/final.png" "face level=/tmp/sp/face/final.png"

docs/img/painter_detail.png, 5000 strokes with the last level on the 256-px canvas and on a finer one:

    python -m nsp.paint strokes=5000 schedule.detail_side=0 hydra.run.dir=/tmp/sp/coarse
    python -m nsp.paint strokes=5000 hydra.run.dir=/tmp/sp/fine
    python docs/img/before_after.py docs/img/painter_detail.png "last level 256 px=/tmp/sp/coarse/final.png" "finer last level=/tmp/sp/fine/final.png"
"""
import argparse

import skimage.data
from PIL import Image, ImageDraw

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("out")
parser.add_argument("pairs", nargs="+", metavar="LABEL=final.png")
parser.add_argument("--cell", type=int, default=256, help="the side of each picture, in pixels")
args = parser.parse_args()
out, pairs, cell = args.out, args.pairs, args.cell
paintings = [(label, Image.open(path).convert("RGB")) for label, path in (pair.rsplit("=", 1) for pair in pairs)]
size = paintings[0][1].size
photo = Image.fromarray(skimage.data.astronaut()).resize(size, Image.Resampling.LANCZOS)
face = tuple(round(v * size[0] / 1024) for v in (300, 140, 620, 460))  # the face in 1024-px coordinates
sheet = Image.new("RGB", ((len(paintings) + 1) * cell, 2 * cell + 20), "white")
for column, (label, image) in enumerate([*paintings, ("photo", photo)]):
    sheet.paste(image.resize((cell, cell), Image.Resampling.BOX), (column * cell, 20))
    sheet.paste(image.crop(face).resize((cell, cell), Image.Resampling.LANCZOS), (column * cell, 20 + cell))
    ImageDraw.Draw(sheet).text((column * cell + 4, 4), label, fill="black")
sheet.quantize(256).save(out, optimize=True)
