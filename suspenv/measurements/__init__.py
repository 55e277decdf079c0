"""Recordings: one test's time histories with units and metadata, and converters.

See ``docs/recordings.md`` for the file format. The shared real data is found by one rule,
:func:`data_dir`; the named real cases are in :mod:`suspenv.measurements.catalog`.
A recording holds SI units only (:mod:`suspenv.measurements.units`: readers convert
declared units or refuse them); every reader bounds the memory a file may take before
reading it (:mod:`suspenv.measurements.limits`, ``$SUSPENV_MAX_READ_BYTES``).
"""

from suspenv.measurements.differentiate import smooth_derivative
from suspenv.measurements.dispatch import SUGGESTED_MODEL, read_recording
from suspenv.measurements.errors import RecordingError
from suspenv.measurements.io import load_recording, save_recording
from suspenv.measurements.paths import data_dir
from suspenv.measurements.recording import Recording
from suspenv.measurements.sources import (
    load_damper_dyno,
    load_emps,
    load_emps_csv,
    load_mr_damper,
)
from suspenv.measurements.units import to_si

__all__ = [
    "SUGGESTED_MODEL",
    "Recording",
    "RecordingError",
    "data_dir",
    "load_damper_dyno",
    "load_emps",
    "load_emps_csv",
    "load_mr_damper",
    "load_recording",
    "read_recording",
    "save_recording",
    "smooth_derivative",
    "to_si",
]
