"""Open any supported recording file by its content: suspenv ``.npz`` or a real-data source.

``read_recording(path)`` picks the reader: ``.npz`` -> :func:`load_recording`;
``.mat`` with ``qm`` -> EMPS, with ``x_F`` -> MR damper; ``.dat`` -> damper dyno;
``.csv`` with ``q_meas`` -> resampled EMPS. Converted recordings carry
``meta["suggested_model"]``, the component family that fits them.

Every reader bounds memory before it reads (``max_bytes``, default
``$SUSPENV_MAX_READ_BYTES`` or 512 MiB; :mod:`suspenv.measurements.limits`) and
converts declared units to SI or refuses them; every failure is a
:class:`~suspenv.measurements.RecordingError` (a ``ValidationError``) naming the file
and the rule.
"""

from __future__ import annotations

from pathlib import Path

from suspenv.measurements.errors import RecordingError
from suspenv.measurements.io import load_recording
from suspenv.measurements.recording import Recording
from suspenv.measurements.sources import load_damper_dyno, load_emps, load_emps_csv, load_mr_damper
from suspenv.measurements.sources._common import load_mat, require_file

#: test name -> component family suited to it
SUGGESTED_MODEL = {
    "emps_trajectory": "friction_guide",
    "emps_pulses": "friction_guide",
    "damper_dyno": "damper",
    "dyno_sine": "damper",
    "mr_sine": "mr_damper",
    "mr_validation": "mr_damper",
    "rig_road": "quarter_car_rig",
}


def read_recording(path: str | Path, *, max_bytes: int | None = None) -> Recording:
    """Load ``path`` with the reader its extension and content call for (``max_bytes``:
    the read limit, :mod:`suspenv.measurements.limits`)."""
    path = require_file(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        rec = load_recording(path, max_bytes=max_bytes)
    elif suffix == ".mat":
        names = load_mat(path, (), max_bytes)["__present__"]
        if "qm" in names:
            rec = load_emps(path, max_bytes=max_bytes)
        elif "x_F" in names:
            rec = load_mr_damper(path, max_bytes=max_bytes)
        else:
            raise RecordingError(
                f"{path.name}: unknown .mat layout; expected 'qm' (EMPS) or 'x_F' (MR damper), "
                f"found {sorted(names)}"
            )
    elif suffix == ".dat":
        rec = load_damper_dyno(path, max_bytes=max_bytes)
    elif suffix == ".csv":
        rec = load_emps_csv(path, max_bytes=max_bytes)
    else:
        raise RecordingError(
            f"{path.name}: unknown recording type {suffix!r}; supported: .npz, .mat, .dat, .csv"
        )
    if rec.test in SUGGESTED_MODEL:
        rec.meta.setdefault("suggested_model", SUGGESTED_MODEL[rec.test])
    return rec
