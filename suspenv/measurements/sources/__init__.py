"""Converters from the real recordings' native files to :class:`Recording` (SI units)."""

from suspenv.measurements.sources.damper_dyno import load_damper_dyno
from suspenv.measurements.sources.emps import load_emps, load_emps_csv
from suspenv.measurements.sources.mr_damper import load_mr_damper
from suspenv.measurements.sources.road_profile import load_profile_txt, profile_recording

__all__ = [
    "load_damper_dyno",
    "load_emps",
    "load_emps_csv",
    "load_mr_damper",
    "load_profile_txt",
    "profile_recording",
]
