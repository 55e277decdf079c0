"""Recordings: one test's time histories with units and metadata, and converters.

See ``docs/recordings.md`` for the file format.
"""

from suspenv.recordings.differentiate import smooth_derivative
from suspenv.recordings.dispatch import SUGGESTED_MODEL, read_recording
from suspenv.recordings.errors import RecordingError
from suspenv.recordings.io import load_recording, save_recording
from suspenv.recordings.recording import Recording
from suspenv.recordings.sources import (
    load_damper_dyno,
    load_emps,
    load_emps_csv,
    load_mr_damper,
)
from suspenv.recordings.units import to_si

__all__ = [
    "SUGGESTED_MODEL",
    "Recording",
    "RecordingError",
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
