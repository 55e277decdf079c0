"""Viscoelastic elements: Kelvin-Voigt and Maxwell.

Units SI: deflection x [m], velocity v [m/s], force [N], time [s]. Sign convention:
force positive when it resists positive deflection (compression positive).

* Kelvin-Voigt (spring ``k`` parallel to dashpot ``c``): ``F = k x + c v``.
* Maxwell (spring ``k_m`` [N/m] in series with dashpot ``c_m`` [N s/m]), state = its
  force ``F``::

      dF/dt = k_m (v - F / c_m)

  relaxation time ``tau = c_m / k_m``. Under ``x = A sin(wt)`` its complex stiffness
  is ``K* = k_m i w tau / (1 + i w tau)``: the force leads the displacement by
  ``atan(1 / (w tau))`` and the loop area (energy per cycle) is
  ``pi A^2 k_m w tau / (1 + (w tau)^2)``. Loop width therefore depends on rate,
  unlike Dahl/Bouc-Wen hysteresis.

The series form steps the Maxwell equation exactly for a displacement that is
linear within each sample interval (velocity constant over the interval).
"""

from __future__ import annotations

import numpy as np

from suspenv.models.effects._util import (
    Value,
    batch_param,
    linear_recurrence,
    require_positive,
    series,
    time_steps,
)


def kelvin_voigt(x: Value, v: Value, k: Value, c: Value) -> Value:
    """Kelvin-Voigt force ``k x + c v`` [N]."""
    return k * x + c * v


def maxwell_dfdt(f: Value, v: Value, k_m: Value, c_m: Value) -> Value:
    """Maxwell element force derivative dF/dt [N/s]."""
    return k_m * (v - f / c_m)


def maxwell_series(
    x: np.ndarray, t: np.ndarray, k_m: Value, c_m: Value, f0: Value = 0.0
) -> np.ndarray:
    """Maxwell force [N] for a deflection history ``x[..., T]`` [m] sampled at ``t[T]`` [s]."""
    x = series(x)
    dt = time_steps(t, x.shape[-1])
    require_positive("k_m", k_m)
    require_positive("c_m", c_m)
    km, cm = batch_param(k_m), batch_param(c_m)
    v = np.diff(x, axis=-1) / dt
    decay = np.exp(-dt / (cm / km))
    # F[k+1] = c v + (F[k] - c v) decay over each interval (v constant)
    return linear_recurrence(cm * v * (1.0 - decay), decay, f0)
