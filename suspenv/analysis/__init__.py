"""Benchmark analysis of finished runs: the views COCO and IOHanalyzer users work with.

- :mod:`~suspenv.analysis.load`: run directories as records and tidy tables
  (:func:`tidy`, :func:`runs_table`: plain dicts of NumPy arrays for
  ``pandas.DataFrame``), configuration hashes.
- :mod:`~suspenv.analysis.compare`: grouping by full configuration, pooling refusals,
  fixed-budget and fixed-target views, rank tests (:func:`compare`), ``compare.json`` /
  ``compare.md`` (:func:`write_compare_files`).
- :mod:`~suspenv.analysis.performance`: best-so-far quantiles, targets, runtimes, ERT,
  runtime ECDF, performance profiles.
- :mod:`~suspenv.analysis.indicators`: hypervolume, IGD, reference fronts.
- :mod:`~suspenv.analysis.stats`: Friedman and Mann-Whitney with Holm correction.
- :mod:`~suspenv.analysis.ioh`: IOHprofiler export (IOHanalyzer).

Figures are drawn by :mod:`suspenv.reports.analysis`; definitions in ``docs/analysis.md``.
"""

from suspenv.analysis.compare import Comparison, compare, write_compare_files
from suspenv.analysis.indicators import hypervolume, igd
from suspenv.analysis.load import RunRecord, config_hash, load_run, load_runs, runs_table, tidy
from suspenv.analysis.performance import (
    ert,
    make_targets,
    performance_profile,
    runtime_ecdf,
    runtimes,
)
from suspenv.analysis.stats import rank_tests

__all__ = [
    "Comparison",
    "RunRecord",
    "compare",
    "config_hash",
    "ert",
    "hypervolume",
    "igd",
    "load_run",
    "load_runs",
    "make_targets",
    "performance_profile",
    "rank_tests",
    "runs_table",
    "runtime_ecdf",
    "runtimes",
    "tidy",
    "write_compare_files",
]
