"""MR damper on a shaking table (``ensaio*.mat``) -> :class:`Recording` in SI.

Source: Labcontrol (UTFPR), "Shaking table with MR-damper", A. N. Vargas, 2021,
Zenodo, MIT licence. Variables used: ``Tout`` time [s], ``x_F`` N x 3 =
[position (mm), velocity (mm/s), force (N)], ``f`` excitation frequency [Hz],
``Ts`` sample time [s].

Channels (SI): inputs ``displacement`` [m] and ``velocity`` [m/s] (the file's own
velocity column converted from mm/s), output ``force`` [N]. Sign convention: the
displacement keeps the table's sign; the force sign is chosen so that the damper
absorbs power on average (``mean(F v) > 0``), recorded in ``meta["force_sign"]``.
The force column carries a static offset (sensor zero / preload) which is kept.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspenv.measurements.errors import RecordingError
from suspenv.measurements.recording import Recording
from suspenv.measurements.sources._common import (
    dissipative_sign,
    load_mat,
    mat_field,
    mat_scalar,
    named_errors,
    require_file,
)
from suspenv.measurements.units import to_si

SOURCE = "Labcontrol UTFPR shaking table with MR damper (A. N. Vargas, 2021, Zenodo), MIT"


def load_mr_damper(
    path: str | Path, name: str | None = None, *, max_bytes: int | None = None
) -> Recording:
    """Load one ``ensaio*.mat`` run; see the module docstring for channels and signs.

    The file's columns are in fixed units (mm, mm/s, N), converted to SI here.
    ``max_bytes``: read limit (:mod:`suspenv.measurements.limits`)."""
    path = require_file(path)
    data = load_mat(path, ("Tout", "x_F", "f"), max_bytes)
    t = mat_field(data, "Tout", path).ravel()
    xf = mat_field(data, "x_F", path)
    if xf.ndim != 2 or xf.shape[1] != 3 or xf.shape[0] != t.size:
        raise RecordingError(
            f"{path.name}: 'x_F' must be N x 3 [position mm, velocity mm/s, force N] with "
            f"N = len(Tout) = {t.size}, but has shape {xf.shape}"
        )
    x, _ = to_si(xf[:, 0], "mm")
    v, _ = to_si(xf[:, 1], "mm/s")
    f = xf[:, 2]
    sign = dissipative_sign(f - np.mean(f), v)
    meta = {
        "source": SOURCE,
        "file": path.name,
        "sampling": {"dt_s": float(np.median(np.diff(t)))},
        "force_sign": sign,
        "notes": "velocity from the file's own column; force offset kept",
    }
    if "f" in data:
        meta["excitation_hz"] = mat_scalar(data, "f", path)
    test = "mr_validation" if ".vali" in path.name else "mr_sine"
    with named_errors(path):
        return Recording(
            name or path.stem,
            test,
            t,
            {"displacement": x, "velocity": v},
            {"force": sign * f},
            {"displacement": "m", "velocity": "m/s", "force": "N"},
            meta,
        )
