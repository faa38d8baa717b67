"""The painter (paper §3.1): parameter search for strokes that reproduce a target image.

- :mod:`~nsp.painter.painter` — the search, level by level, each block's active set a stroke at a time;
- :mod:`~nsp.painter.blocks` — the progressive schedule's geometry and stroke counts;
- :mod:`~nsp.painter.placement` — where and in what colour a new stroke starts;
- :mod:`~nsp.painter.renderer` — ``analytic`` (soft vector engine) and ``neural`` renderers;
- :mod:`~nsp.painter.losses`, :mod:`~nsp.painter.transport` — L1 and the transportation loss;
- :mod:`~nsp.painter.optimize`, :mod:`~nsp.painter.palette`, :mod:`~nsp.painter.structure`,
  :mod:`~nsp.painter.faces` — the optimizer, the colours a stroke may take, the image's form, faces;
- :mod:`~nsp.painter.stylize` — restyling painted strokes (§3.5);
- :mod:`~nsp.painter.settings` — the typed settings of the renderer, the loss and the schedule.

The paint command that runs it, its files and logs live in :mod:`nsp.painting`.
"""
