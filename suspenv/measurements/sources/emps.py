"""EMPS (electro-mechanical positioning system) recordings -> :class:`Recording`.

Source: the nonlinear system identification benchmark "EMPS" (A. Janot, M. Gautier,
M. Brunot, 2019). A prismatic joint driven by a motor in closed loop.

Frame and signs: ``position`` [m] is the carriage position along the guide as
measured (``qm``); ``velocity`` [m/s] and ``acceleration`` [m/s^2] are its time
derivatives estimated by the Savitzky-Golay differentiator of
:mod:`suspenv.measurements.differentiate` (window 0.02 s, cubic); ``force`` [N] is
the motor force ``gtau * vir`` acting on the carriage, positive along +position.

For the inverse (force-from-motion) model the motion channels are the inputs and
the force is the output.

The resampled CSV files (``*_SC.csv``, 5 ms) hold scaled channels; the scaling
``q_meas = 8 q - 1`` and ``v_est = 8 v`` (q in m, v in m/s) was established by a
linear regression of the CSV against the .mat record of the same run
(residual 3e-7 in scaled units); ``u_in`` is the motor command in volts.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.measurements.differentiate import smooth_derivative
from suspenv.measurements.errors import RecordingError
from suspenv.measurements.limits import check_text, read_limit
from suspenv.measurements.recording import Recording
from suspenv.measurements.sources._common import (
    load_mat,
    mat_field,
    mat_scalar,
    named_errors,
    require_file,
)

#: motor constant used when a file does not carry ``gtau`` [N/V]
GTAU_DEFAULT = 35.15065188
SOURCE = "EMPS benchmark (Janot, Gautier, Brunot), nonlinear system identification benchmarks"
CSV_POSITION_SCALE = 8.0  # scaled units per metre
CSV_POSITION_OFFSET = -1.0


def _motion_channels(
    q: np.ndarray, t: np.ndarray, window_s: float, path: Path
) -> dict[str, np.ndarray]:
    with named_errors(path):
        return {
            "position": q,
            "velocity": smooth_derivative(q, t, window_s, order=3, deriv=1),
            "acceleration": smooth_derivative(q, t, window_s, order=3, deriv=2),
        }


UNITS = {
    "position": "m",
    "velocity": "m/s",
    "acceleration": "m/s^2",
    "reference_position": "m",
    "force": "N",
}


def load_emps(
    path: str | Path,
    window_s: float = 0.02,
    name: str | None = None,
    *,
    max_bytes: int | None = None,
) -> Recording:
    """Load ``DATA_EMPS*.mat``: inputs position/velocity/acceleration/reference, output force.

    ``max_bytes``: read limit (:mod:`suspenv.measurements.limits`)."""
    path = require_file(path)
    data = load_mat(path, ("t", "qm", "qg", "vir", "gtau", "kp", "kv", "pulses_N"), max_bytes)
    t = mat_field(data, "t", path).ravel()
    qm = mat_field(data, "qm", path).ravel()
    qg = mat_field(data, "qg", path).ravel()
    vir = mat_field(data, "vir", path).ravel()
    gtau = mat_scalar(data, "gtau", path) if "gtau" in data else GTAU_DEFAULT
    for key, arr in (("qm", qm), ("qg", qg), ("vir", vir)):
        if arr.shape != t.shape:
            raise RecordingError(
                f"{path.name}: variable {key!r} must have one value per time sample "
                f"{t.shape}, but has shape {arr.shape}"
            )
    inputs = _motion_channels(qm, t, window_s, path)
    inputs["reference_position"] = qg
    dt = float(np.median(np.diff(t)))
    meta: dict[str, Any] = {  # Recording.meta: free JSON-like metadata
        "source": SOURCE,
        "file": path.name,
        "sampling": {"dt_s": dt, "rate_hz": 1.0 / dt},
        "gtau_N_per_V": gtau,
        "differentiator": f"Savitzky-Golay, cubic, window {window_s} s",
        "notes": "motor force = gtau * vir; closed-loop positioning run",
    }
    for key in ("kp", "kv"):
        if key in data:
            meta[key] = mat_scalar(data, key, path)
    if "pulses_N" in data:
        meta["notes"] += "; validation run with force pulses (pulses_N flags them)"
        meta["pulse_samples"] = int(np.count_nonzero(mat_field(data, "pulses_N", path)))
    return _recording(path, name, t, inputs, gtau * vir, meta)


def load_emps_csv(
    path: str | Path,
    window_s: float = 0.02,
    name: str | None = None,
    *,
    max_bytes: int | None = None,
) -> Recording:
    """Load a resampled ``DATA_EMPS*_SC.csv`` (``time_exp, q_ref, q_meas, v_est, u_in, u_tot``).

    The columns carry no units: they are the benchmark's scaled units, de-scaled as the
    module docstring says. ``max_bytes``: read limit (:mod:`suspenv.measurements.limits`;
    a text file may be a quarter of it)."""
    path = require_file(path)
    check_text(path, read_limit(max_bytes))
    with open(path, encoding="utf-8", errors="replace") as fh:
        header = [h.strip() for h in fh.readline().split(",")]
    needed = ["time_exp", "q_ref", "q_meas", "u_in"]
    missing = [c for c in needed if c not in header]
    if missing:
        raise RecordingError(f"{path.name}: missing column(s) {missing}; header is {header}")
    if len(set(header)) < len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise RecordingError(f"{path.name}: column name(s) {dup} repeat; header is {header}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
    except (ValueError, UnicodeDecodeError) as exc:
        raise RecordingError(f"{path.name}: the data rows are not numbers ({exc})") from None
    if table.shape[1] != len(header):
        raise RecordingError(
            f"{path.name}: {len(header)} column names but {table.shape[1]} columns of data"
        )
    if table.shape[0] < 2:
        raise RecordingError(f"{path.name}: {table.shape[0]} data row(s); at least 2 needed")
    col = {h: table[:, i] for i, h in enumerate(header)}
    t = col["time_exp"]
    q = (col["q_meas"] - CSV_POSITION_OFFSET) / CSV_POSITION_SCALE
    inputs = _motion_channels(q, t, window_s, path)
    inputs["reference_position"] = (col["q_ref"] - CSV_POSITION_OFFSET) / CSV_POSITION_SCALE
    meta = {
        "source": SOURCE,
        "file": path.name,
        "sampling": {"dt_s": float(np.median(np.diff(t)))},
        "gtau_N_per_V": GTAU_DEFAULT,
        "differentiator": f"Savitzky-Golay, cubic, window {window_s} s",
        "notes": "de-scaled from the CSV's scaled units (q = (q_meas + 1)/8)",
    }
    return _recording(path, name, t, inputs, GTAU_DEFAULT * col["u_in"], meta)


def _recording(
    path: Path,
    name: str | None,
    t: np.ndarray,
    inputs: dict[str, np.ndarray],
    force: np.ndarray,
    meta: dict[str, Any],
) -> Recording:
    """The recording of an EMPS run (test ``emps_pulses`` when the file's name says
    PULSES, else ``emps_trajectory``); output ``force`` [N]."""
    test = "emps_pulses" if "PULSES" in path.name.upper() else "emps_trajectory"
    with named_errors(path):
        return Recording(name or path.stem, test, t, inputs, {"force": force}, dict(UNITS), meta)
