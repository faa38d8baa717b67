"""``python -m nsp.paint``'s run of the painter (:mod:`nsp.painter`): its config, its files, its logs.

- :mod:`~nsp.painting.schema` — the command's typed config (:func:`~nsp.painting.schema.paint_settings`);
- :mod:`~nsp.painting.run` — ``paint(cfg)``: check the inputs, paint, style, write the files;
- :mod:`~nsp.painting.outputs` — final.png, strokes.json, painting.svg, animation.gif and the scores;
- :mod:`~nsp.painting.callbacks` — the progress bar and TensorBoard.
"""
