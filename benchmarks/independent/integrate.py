"""Time integration and exact linear filters.

* :func:`integrate` -- an ODE ``dy/dt = f(t, y)`` solved with
  :func:`scipy.integrate.solve_ivp` (LSODA by default: Adams for non-stiff stretches,
  BDF for stiff ones, Hindmarsh 1983 / Petzold 1983; or Radau IIA, Hairer and Wanner
  1996) with tight tolerances and sampled at the recording's times from the solver's
  dense output;
* :func:`first_order_lag` -- ``tau y' + y = u`` discretised exactly for a ``u`` that is
  linear between samples (first-order hold);
* :func:`delayed` -- ``u(t - d)`` by cubic-spline interpolation of the samples.

Units follow the caller: times [s], states in the units of the model.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter


class IntegrationError(RuntimeError):
    """The ODE solver stopped before the end of the recording."""


def integrate(
    rhs: Callable[[float, np.ndarray], np.ndarray],
    y0: np.ndarray,
    t: np.ndarray,
    *,
    method: str = "LSODA",
    rtol: float = 1e-8,
    atol: float | np.ndarray = 1e-10,
    max_step: float | None = None,
) -> np.ndarray:
    """States at the sample times ``t`` [s], shape ``(len(t), len(y0))``.

    ``t`` must be increasing; the initial state ``y0`` is the state at ``t[0]``. The step
    is at most ``max_step`` [s] (default four sample intervals, so that an excitation that
    starts after a rest is never stepped over). Raises :class:`IntegrationError` when the
    solver fails.
    """
    y0 = np.asarray(y0, dtype=float)
    if y0.size == 0:
        return np.zeros((t.size, 0))
    if max_step is None:
        max_step = 4.0 * float(t[1] - t[0]) if t.size > 1 else math.inf
    sol = solve_ivp(
        rhs,
        (float(t[0]), float(t[-1])),
        y0,
        method=method,
        t_eval=t,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
    )
    if sol.status != 0 or sol.y.shape[1] != t.size:
        raise IntegrationError(f"{method} stopped at t={sol.t[-1]:.6g} s: {sol.message}")
    return np.asarray(sol.y.T)


def first_order_lag(u: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """Output of ``tau y' + y = u`` [units of ``u``], ``y(0) = u(0)``, sample interval ``dt``.

    Exact for ``u`` linear between samples:
    ``y[k+1] = a y[k] + (1 - a) u[k] + (1 - tau (1 - a) / dt) (u[k+1] - u[k])``,
    ``a = exp(-dt / tau)``.
    """
    if tau <= 0.0:
        return np.array(u, dtype=float)
    a = math.exp(-dt / tau)
    b0 = 1.0 - tau * (1.0 - a) / dt
    b1 = (1.0 - a) - b0
    u = np.asarray(u, dtype=float)
    # state of the direct-form filter for a steady start y = u[0]
    zi = np.array([u[0] * (1.0 - b0)])
    y, _ = lfilter([b0, b1], [1.0, -a], u, zi=zi)
    return np.asarray(y)


def delayed(u: np.ndarray, t: np.ndarray, delay: float) -> np.ndarray:
    """``u(t - delay)`` at the times ``t`` (cubic spline; held at ``u[0]`` before the start)."""
    spline = CubicSpline(t, u)
    tq = t - delay
    out = np.asarray(spline(np.maximum(tq, t[0])))
    out[tq < t[0]] = u[0]
    return out
