"""The painter (paper §3.1): parameter search for strokes that reproduce a target image.

- :mod:`~nsp.painter.painter` — the search: levels of blocks painted as one batch, strokes added to
  each block's active set one at a time and optimized together;
- :mod:`~nsp.painter.blocks` — the progressive schedule's geometry and stroke counts;
- :mod:`~nsp.painter.placement` — where and in what colour a new stroke starts;
- :mod:`~nsp.painter.renderer` — ``analytic`` (soft vector engine) and ``neural`` renderers;
- :mod:`~nsp.painter.losses`, :mod:`~nsp.painter.transport` — L1 and the transportation loss;
- :mod:`~nsp.painter.outputs`, :mod:`~nsp.painter.callbacks`, :mod:`~nsp.painter.schema` — files
  out, logging, and ``python -m nsp.paint``'s config (photos come in through :mod:`nsp.images`).
"""
