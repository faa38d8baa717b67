"""Turning runs into tables and plots (``python -m nsp.report DIR``).

- :mod:`~nsp.reporting.collect` — finding the jobs of a dir, their choices, status and metrics;
- :mod:`~nsp.reporting.tables` — the job table, the renderer × brush pivot, dual's margins;
- :mod:`~nsp.reporting.plots` — TensorBoard curves and the final-score bar chart;
- :mod:`~nsp.reporting.report` — ``write_report``: all of it into ``report.md`` and ``report.csv``.
"""
from nsp.reporting.collect import Job, collect, latest_sweep
from nsp.reporting.report import write_report

__all__ = ["Job", "collect", "latest_sweep", "write_report"]
