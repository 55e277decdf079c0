"""Sensor imperfections: offset, gain error, first-order lag, pure delay.

A sensor maps the true channel ``y`` to the recorded one. Units follow the channel
(SI inside suspenv); ``offset`` has the channel's unit, ``gain`` is dimensionless,
``tau`` and ``delay`` are in seconds. Sign convention: a positive ``tau``/``delay``
makes the recorded signal late.

* offset and gain: ``y_rec = gain * y + offset``
* first-order lag: ``tau dy_rec/dt = y - y_rec``; under a sinusoid of angular
  frequency ``w`` the recorded signal lags by ``atan(w tau)`` with amplitude ratio
  ``1 / sqrt(1 + (w tau)^2)``.
* pure delay: ``y_rec(t) = y(t - delay)`` (linear interpolation, first value held).
* zero drift: ``y_rec = y + rate t + bow P2(u) + wave P3(u)`` (t in seconds from the
  recording's time origin, ``u = 2 t / span - 1``, held at its value at ``t = span``
  beyond it; the zero at t = 0 is an offset of its own): a load cell or displacement
  transducer whose zero wanders slowly.
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


def sensor_offset_gain(y: Value, offset: Value = 0.0, gain: Value = 1.0) -> np.ndarray:
    """Recorded value ``gain * y + offset`` (pointwise)."""
    return np.asarray(gain, dtype=float) * np.asarray(y, dtype=float) + offset


def sensor_drift(
    y: Value,
    t: np.ndarray | None,
    rate: Value = 0.0,
    bow: Value = 0.0,
    wave: Value = 0.0,
    span: Value = 1.0,
) -> np.ndarray:
    """Recorded value ``y + rate t + bow P2(u) + wave P3(u)``: a zero that drifts slowly
    and smoothly in time. ``t`` [s] from the recording's time origin, ``u = 2 t / span - 1``
    (``span`` [s], the time the drift was fitted over, fixed), P2 and P3 the Legendre
    polynomials (zero mean over the span, so the zero at the start stays with the
    offset); ``rate`` in the channel's unit per second, ``bow`` and ``wave`` in the
    channel's unit. Past the span the drift holds its last value: a cubic fitted over
    one stretch of time says nothing of the next, and extrapolated it grows as the cube
    of the time past the span."""
    if t is None:
        raise ValueError("zero_drift needs the sample times t [s]")
    tt = np.minimum(np.asarray(t, float), np.asarray(span, dtype=float))
    u = 2.0 * tt / np.asarray(span, dtype=float) - 1.0
    p2 = 0.5 * (3.0 * u * u - 1.0)
    p3 = 0.5 * (5.0 * u * u * u - 3.0 * u)  # u * u * u: numpy takes u**3 by a slow pow
    return (
        np.asarray(y, dtype=float)
        + np.asarray(rate, dtype=float) * tt
        + np.asarray(bow, dtype=float) * p2
        + np.asarray(wave, dtype=float) * p3
    )


def sensor_lag(y: np.ndarray, t: np.ndarray, tau: Value) -> np.ndarray:
    """First-order lag of ``y[..., T]`` sampled at ``t[T]``; starts at rest on ``y[..., 0]``.

    Exact for ``y`` linear between samples (first-order-hold discretisation).
    ``tau`` [s] is batch-shaped; ``tau = 0`` returns ``y`` unchanged.
    """
    y = series(y, "y")
    dt = time_steps(t, y.shape[-1])
    require_positive("tau", tau, strict=False)
    ta = batch_param(tau)
    safe = np.where(ta > 0, ta, 1.0)
    slope = np.diff(y, axis=-1) / dt
    e = np.where(ta > 0, np.exp(-dt / safe), 0.0)
    # exact response of tau y' = u - y to u linear over each interval:
    # y[k+1] = u[k+1] - slope tau + (y[k] - u[k] + slope tau) e
    a = y[..., 1:] - slope * safe - (y[..., :-1] - slope * safe) * e
    a = np.where(ta > 0, a, y[..., 1:])
    return linear_recurrence(a, e, y[..., 0])


def sensor_delay(y: np.ndarray, t: np.ndarray, delay: Value) -> np.ndarray:
    """Pure delay of ``y[..., T]`` sampled at ``t[T]``: ``y_rec(t) = y(t - delay)``,
    linear interpolation, the first value held before the record starts.

    ``delay`` [s] is batch-shaped (scalar or broadcast against ``y.shape[:-1]``);
    ``delay = 0`` returns ``y`` unchanged. Under a sinusoid of angular frequency ``w`` the
    recorded signal lags by ``w delay`` at unit amplitude ratio (a first-order lag's
    ratio falls instead).
    """
    y = series(y, "y")
    tt = np.asarray(t, dtype=float)
    time_steps(tt, y.shape[-1])
    require_positive("delay", delay, strict=False)
    da = np.asarray(delay, dtype=float)
    y = np.broadcast_to(y, (*np.broadcast_shapes(da.shape, y.shape[:-1]), y.shape[-1]))
    d = np.broadcast_to(da, y.shape[:-1]).reshape(-1)
    flat = y.reshape(-1, y.shape[-1])
    out = np.stack([np.interp(tt - di, tt, row) for di, row in zip(d, flat, strict=True)])
    return out.reshape(y.shape)
