"""Shared helpers for effect elements: batch broadcasting and input checks.

Conventions used by every effect module:

* Pointwise functions (state derivatives, static curves) follow plain numpy
  broadcasting between all arguments.
* Series functions take a path or time series ``x[..., T]`` (last axis = samples)
  and parameters shaped like the batch ``x.shape[:-1]`` (scalars broadcast); they
  return arrays shaped like ``x``.
"""

from __future__ import annotations

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.sampling import increasing_steps
from suspenv.models.effects import kernels

#: a parameter or input: a number, or an array broadcast against the others
Value = np.ndarray | float


def series(x: Value, name: str = "x") -> np.ndarray:
    """Return ``x`` as a float array with at least one sample axis; reject NaN/inf."""
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 0:
        raise ValidationError(f"`{name}` must be a series with a sample axis, but got a scalar")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        where = tuple(int(i) for i in idx)
        raise ValidationError(f"`{name}` must be finite, but got {arr[where]} at index {where}")
    return arr


def batch_param(p: Value) -> np.ndarray:
    """Turn a batch-shaped parameter (scalar or ``(...,)``) into ``(..., 1)`` for series maths."""
    return np.asarray(p, dtype=float)[..., None]


def require_positive(name: str, value: Value, strict: bool = True, bound: float = 0.0) -> None:
    """Raise :class:`ValidationError` unless all of ``value`` is > ``bound`` (>= if not
    ``strict``)."""
    arr = np.asarray(value, dtype=float)
    ok = arr > bound if strict else arr >= bound
    if not np.all(ok):
        rule = f"`{name} {'>' if strict else '>='} {bound:g}`"
        raise ValidationError(f"{rule} must hold, but got {name}={float(arr[~ok].ravel()[0])}")


def time_steps(t: np.ndarray, n: int) -> np.ndarray:
    """Sample intervals of a strictly increasing time vector ``t`` of length ``n`` [s]."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.shape[0] != n:
        raise ValidationError(
            f"time vector must be 1-D with one entry per sample, but got shape {t.shape} "
            f"for {n} samples"
        )
    return increasing_steps(t)


def linear_recurrence(a: np.ndarray, b: np.ndarray, z0: Value) -> np.ndarray:
    """Solve ``z[k+1] = a[k] + b[k] z[k]`` along the last axis; ``out[..., 0] = z0``.

    ``a`` and ``b`` are ``(..., T-1)`` (broadcast together), ``z0`` batch-shaped
    (a scalar applies to every batch row).
    The coefficients are computed vectorised by the callers; the recurrence itself
    runs compiled (:func:`.kernels.recurrence`).
    """
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    batch = np.broadcast_shapes(a.shape[:-1], np.shape(z0))
    a = np.broadcast_to(a, batch + a.shape[-1:]).reshape(-1, a.shape[-1])
    b = np.broadcast_to(b, batch + b.shape[-1:]).reshape(-1, b.shape[-1])
    z0f = np.broadcast_to(np.asarray(z0, dtype=float), batch).reshape(-1)
    out = np.empty((a.shape[0], a.shape[1] + 1))
    args = (np.ascontiguousarray(v, dtype=float) for v in (a, b, z0f))
    kernels.recurrence(*args, out)
    return out.reshape(batch + (a.shape[1] + 1,))
