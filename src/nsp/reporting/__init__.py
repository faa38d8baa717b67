"""Turning runs into tables and plots (``python -m nsp.report DIR``): :mod:`~nsp.reporting.collect` reads
the jobs, :mod:`~nsp.reporting.tables` and :mod:`~nsp.reporting.plots` show them, and
:func:`write_report` writes them into ``report.md`` and ``report.csv``."""
from nsp.reporting.collect import Job, collect, latest_sweep
from nsp.reporting.report import write_report

__all__ = ["Job", "collect", "latest_sweep", "write_report"]
