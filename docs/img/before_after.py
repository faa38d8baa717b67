"""docs/img/painter_before_after.png: the demo painting before and after issue 11, and the photo.

Row 1: the whole demo (256 px); row 2: the face, from the 1024-px final.png. Make the two paintings
first, then this image:

    git worktree add /tmp/before 0cca65e && (cd /tmp/before && python -m nsp.paint hydra.run.dir=/tmp/sp/base_demo)
    python -m nsp.paint hydra.run.dir=/tmp/sp/after_demo
    python docs/img/before_after.py /tmp/sp/base_demo/final.png /tmp/sp/after_demo/final.png
"""
import sys
from pathlib import Path

import skimage.data
from PIL import Image, ImageDraw

before, after = (Image.open(path).convert("RGB") for path in sys.argv[1:3])
photo = Image.fromarray(skimage.data.astronaut()).resize(before.size, Image.Resampling.LANCZOS)
face = (300, 140, 620, 460)  # the face in 1024-px coordinates
cell = 256
sheet = Image.new("RGB", (3 * cell, 2 * cell + 20), "white")
for column, (image, label) in enumerate([(before, "before"), (after, "after"), (photo, "photo")]):
    sheet.paste(image.resize((cell, cell), Image.Resampling.BOX), (column * cell, 20))
    sheet.paste(image.crop(face).resize((cell, cell), Image.Resampling.LANCZOS), (column * cell, 20 + cell))
    ImageDraw.Draw(sheet).text((column * cell + 4, 4), label, fill="black")
sheet.quantize(256).save(Path(__file__).with_name("painter_before_after.png"), optimize=True)
