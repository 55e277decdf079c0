"""Handling metrics: ISO 7401 yaw-rate response of a linear handling system (SI units:
s, rad, Hz). The slalom runs live with the handling rigs (:mod:`suspenv.rigs.handling`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from suspenv.models.minibus import handling_kernel


# ------------------------------------------------------------------ ISO 7401
@dataclass
class YawResponse:
    """ISO 7401 yaw-rate response of a linear handling system (arrays (n,)).

    Attributes:
        gain: 1/s, steady yaw rate per rad of road-wheel steer.
        response_time: s, from a steer step to 90 % of the steady yaw rate (ISO 7401's
            response time, measured from 50 % of the steer input: an ideal step).
        peak_time: s, to the yaw rate's first peak (``t_end`` when it has none).
        overshoot: -, peak yaw rate over the steady one, minus 1 (0 without a peak).
        bandwidth: Hz, lowest frequency at which the yaw-rate gain has fallen to
            ``1/sqrt(2)`` of the steady gain (``f_max`` where it has not).
    """

    gain: np.ndarray
    response_time: np.ndarray
    peak_time: np.ndarray
    overshoot: np.ndarray
    bandwidth: np.ndarray


def yaw_response(
    A: np.ndarray,
    B: np.ndarray,
    t_end: float = 3.0,
    dt: float = 0.01,
    f_max: float = 5.0,
    modes: tuple[np.ndarray, np.ndarray] | None = None,
) -> YawResponse:
    """Step and frequency response of the yaw rate of the linear system ``(A, B)``
    (:func:`suspenv.models.minibus.handling_model.linear_system`, state (v, r, phi, p),
    unit road-wheel steer), in closed form through the eigen-decomposition ``A = V
    diag(lam) V^-1``: with ``w = (V^-1 B)_k V[r, k] / lam_k``, the step response is
    ``r(t) = sum_k w_k (e^(lam_k t) - 1)`` and the frequency response ``H(f) = sum_k w_k
    lam_k / (i 2 pi f - lam_k)``. The 90 % crossing and the first peak are found on a
    grid of ``dt`` (s) up to ``t_end`` and refined by Newton steps on the closed form,
    the bandwidth on a log grid to ``f_max`` (Hz) refined by regula falsi in log f (both
    to round-off; the compiled :func:`suspenv.models.minibus.handling_kernel.yaw_loop`,
    ``x(inf) = -A^-1 B`` the steady state). Rows must be stable. ``modes``:
    ``np.linalg.eig(A)`` if already at hand."""
    lam, V = modes if modes is not None else np.linalg.eig(A)
    out = np.empty((A.shape[0], 6))
    lam, V = np.ascontiguousarray(lam, dtype=complex), np.ascontiguousarray(V, dtype=complex)
    B = np.ascontiguousarray(B, dtype=float)
    handling_kernel.yaw_loop(lam, V, B, _grid(t_end, dt), _log_grid(f_max), float(f_max), out)
    has_peak = out[:, 2] > 0
    return YawResponse(
        gain=out[:, 5],
        response_time=out[:, 0],
        peak_time=np.where(has_peak, out[:, 1], t_end),
        overshoot=np.where(has_peak, np.maximum(out[:, 3] - 1.0, 0.0), 0.0),
        bandwidth=out[:, 4],
    )


@functools.lru_cache(maxsize=4)
def _grid(t_end: float, dt: float) -> np.ndarray:
    """Times 0, dt, .. t_end (s) of the step response's search grid (read-only, cached)."""
    t = np.arange(0.0, t_end + 0.5 * dt, dt)
    t.flags.writeable = False
    return t


@functools.lru_cache(maxsize=4)
def _log_grid(f_max: float) -> np.ndarray:
    """48 log-spaced frequencies 0.01..``f_max`` Hz (read-only, cached)."""
    f = np.geomspace(0.01, f_max, 48)
    f.flags.writeable = False
    return f
