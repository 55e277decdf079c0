"""Smoothing differentiator for measured displacement.

Velocity (and acceleration) are estimated with a Savitzky-Golay filter: a local
least-squares polynomial of ``order`` over a centred window of ``window_s``
seconds, differentiated analytically. It is exact for polynomials up to
``order`` and has no phase error (centred window). For a sinusoid of angular
frequency ``w`` the cubic first-derivative gain error is about
``(w window_s)^4 / 7000`` (fitted to the measured response, e.g. 3.6e-4 at 10 Hz
with a 20 ms window). Units: ``x`` [m], ``t`` [s], result [m/s] or [m/s^2].
Requires finite values and uniform, strictly increasing sampling (checked to 1 %);
a breach raises :class:`~suspenv.measurements.RecordingError` naming the sample.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter

from suspenv.core.sampling import increasing_steps
from suspenv.measurements.errors import RecordingError


def smooth_derivative(
    x: np.ndarray, t: np.ndarray, window_s: float = 0.02, order: int = 3, deriv: int = 1
) -> np.ndarray:
    """Derivative ``deriv`` (1 or 2) of ``x`` over uniformly sampled ``t`` (Savitzky-Golay)."""
    x, t = np.asarray(x, dtype=float), np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2 or x.shape[-1:] != t.shape:
        raise RecordingError(
            f"smooth_derivative needs 1-D t of length >= 2 and x with one value per time "
            f"along its last axis, but got shapes {x.shape} and {t.shape}"
        )
    if not np.all(np.isfinite(t)):
        i = int(np.argmax(~np.isfinite(t)))
        raise RecordingError(f"smooth_derivative needs finite times, but t[{i}] = {t[i]}")
    if not np.all(np.isfinite(x)):
        i = int(np.argmax(~np.isfinite(x.reshape(-1))))
        raise RecordingError(
            f"smooth_derivative needs finite values, but value {i} is {x.reshape(-1)[i]} "
            f"({int(np.count_nonzero(~np.isfinite(x)))} non-finite)"
        )
    dt = increasing_steps(t, "smooth_derivative: ", error=RecordingError)
    h = float(np.median(dt))
    if np.max(np.abs(dt - h)) > 0.01 * h:
        i = int(np.argmax(np.abs(dt - h)))
        raise RecordingError(
            f"smooth_derivative needs uniform sampling (to 1 %), but the interval at sample "
            f"{i} is {dt[i]:.6g} s against a median of {h:.6g} s"
        )
    n = int(round(window_s / h)) | 1  # odd number of samples
    n = max(n, order + 2 if (order + 2) % 2 else order + 3)
    if n > x.size:
        raise RecordingError(
            f"smoothing window of {n} samples is longer than the series ({x.size} samples)"
        )
    return savgol_filter(x, n, order, deriv=deriv, delta=h)
