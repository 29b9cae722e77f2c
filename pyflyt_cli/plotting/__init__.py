"""Benchmark statistics and figures with rliable (``pyflyt plot``); no Hydra, no engine physics.

* :func:`load_benchmark` — a benchmark directory as aligned, normalised score arrays.
* :mod:`pyflyt_cli.plotting.stats` — IQM, aggregates, curves, profiles, probability of
  improvement, each with seeded 95 % stratified-bootstrap intervals.
* :func:`plot_benchmark` — all of it to PNG/SVG figures, ``report.md`` and ``report.json``.
"""

from pyflyt_cli.plotting.data import Benchmark, Normalisation, RunCurve, load_benchmark
from pyflyt_cli.plotting.report import Report, plot_benchmark

__all__ = ["Benchmark", "Normalisation", "Report", "RunCurve", "load_benchmark", "plot_benchmark"]
