"""Training neural renderers (paper §3.2, §4).

- :mod:`~nsp.training.run` — ``train(cfg)``: a whole run, its callbacks and its metrics;
- :mod:`~nsp.training.module` — the Lightning module (loss, PSNR, the validation grid);
- :mod:`~nsp.training.data` — random strokes drawn by the vector engine, the seeded validation and test sets;
- :mod:`~nsp.training.schema`, :mod:`~nsp.training.checks` — ``python -m nsp.train``'s config and its checks;
- :mod:`~nsp.training.logger`, :mod:`~nsp.training.progress` — TensorBoard and the progress bar.
"""
