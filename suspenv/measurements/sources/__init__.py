"""Converters from the real recordings' native files to :class:`Recording` (SI units)."""

from suspenv.measurements.sources.damper_dyno import load_damper_dyno
from suspenv.measurements.sources.emps import load_emps, load_emps_csv
from suspenv.measurements.sources.mr_damper import load_mr_damper

__all__ = ["load_damper_dyno", "load_emps", "load_emps_csv", "load_mr_damper"]
