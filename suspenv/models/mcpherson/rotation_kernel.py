"""Compiled loops of the rotation updates (numba): ``expm(w) R`` and ``log(A B^T)`` row by row.

The same formulas as :func:`~suspenv.models.mcpherson.rotation.expm_so3` (Rodrigues) and
:func:`~suspenv.models.mcpherson.rotation.log_so3` (skew part times ``t / (2 sin t)``),
one 3 x 3 matrix at a time, their trigonometric factors summed as power series below
about 7 degrees (:data:`SERIES_BELOW`; the same numbers to rounding): the Newton updates and
predictors of the K&C sweep turn a few rows per call, where numpy's per-call overhead
dominates. Rotation vectors in radians; matrices map body axes to vehicle axes.
``tests/test_knc_rows_last.py`` compares them with the stacked products.
"""

from __future__ import annotations

import math

import numpy as np

from suspenv.core import compiled

#: numba is there: the compiled loops can run (compiled at the first call)
AVAILABLE = compiled.AVAILABLE


#: below this squared angle [rad^2] (about 7 degrees) :func:`_log` and :func:`_expm` sum
#: power series in it instead of calling ``atan2``, ``sin`` and ``cos`` (the rotations of
#: a rig step and of the bushings, a tenth of the time; their last terms below 1e-20
#: relative there)
SERIES_BELOW = 1.0 / 64.0
#: ``t / (2 sin t) = asin(s) / (2 s)`` in powers of ``s^2`` (``s = sin t``, ``t`` below
#: 90 degrees): ``(2k)! / (4^k k!^2 (2k + 1)) / 2``
_LOG_SERIES = (
    0.5, 0.08333333333333333, 0.0375, 0.022321428571428572, 0.015190972222222222,
    0.011186079545454546, 0.008676382211538462, 0.006982421875, 0.0057759004480698525,
    0.004880804764597039,
)  # fmt: skip
#: ``sin(t) / t`` and ``(1 - cos t) / t^2`` in powers of ``t^2``: ``(-1)^k / (2k + 1)!``
#: and ``(-1)^k / (2k + 2)!``
_SIN_SERIES = (
    1.0, -0.16666666666666666, 0.008333333333333333, -0.0001984126984126984,
    2.7557319223985893e-06, -2.505210838544172e-08,
)  # fmt: skip
_COS_SERIES = (
    0.5, -0.041666666666666664, 0.001388888888888889, -2.48015873015873e-05,
    2.755731922398589e-07, -2.08767569878681e-09,
)  # fmt: skip


def _series(x: float, coefficients: tuple) -> float:
    """The power series ``sum_k coefficients[k] x^k`` (Horner)."""
    acc = coefficients[-1]
    for k in range(len(coefficients) - 2, -1, -1):
        acc = acc * x + coefficients[k]
    return acc


def _log(R: np.ndarray, out: np.ndarray) -> None:
    """Rotation vector [rad] of the rotation matrix ``R`` (3, 3) into ``out`` (3,)."""
    v0 = R[2, 1] - R[1, 2]
    v1 = R[0, 2] - R[2, 0]
    v2 = R[1, 0] - R[0, 1]
    s2 = 0.25 * (v0 * v0 + v1 * v1 + v2 * v2)
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    if s2 < SERIES_BELOW and c > 0.0:
        f = _series(s2, _LOG_SERIES)
    else:
        s = math.sqrt(s2)
        th = math.atan2(s, c)
        f = 0.5 + th * th / 12.0 if s < 1e-8 else th / (2.0 * s)
    out[0], out[1], out[2] = v0 * f, v1 * f, v2 * f


def _expm(x: float, y: float, z: float, E: np.ndarray) -> None:
    """The rotation matrix ``expm([x, y, z])`` (rotation vector [rad]) into ``E`` (3, 3)."""
    th2 = x * x + y * y + z * z
    if th2 < SERIES_BELOW:
        A = _series(th2, _SIN_SERIES)
        B = _series(th2, _COS_SERIES)
    else:
        th = math.sqrt(th2)
        A = math.sin(th) / th
        B = (1.0 - math.cos(th)) / (th * th)
    C = 1.0 - B * th2
    Bx = B * x
    Bxy, Bxz, Byz = Bx * y, Bx * z, B * y * z
    E[0, 0], E[0, 1], E[0, 2] = C + Bx * x, Bxy - A * z, Bxz + A * y
    E[1, 0], E[1, 1], E[1, 2] = Bxy + A * z, C + B * y * y, Byz - A * x
    E[2, 0], E[2, 1], E[2, 2] = Bxz - A * y, Byz + A * x, C + B * z * z


def _turned(w: np.ndarray, R: np.ndarray, out: np.ndarray) -> None:
    """``expm(w[i]) @ R[i]`` into ``out[i]`` for rotation vectors ``w`` (N, 3) and
    matrices ``R`` (N, 3, 3)."""
    E = np.empty((3, 3))
    for i in range(w.shape[0]):
        _expm(w[i, 0], w[i, 1], w[i, 2], E)
        _times(E, R[i], out[i])


def _times(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    """``out = A @ B`` for (3, 3) matrices (``out`` not one of them)."""
    for a in range(3):
        for b in range(3):
            out[a, b] = A[a, 0] * B[0, b] + A[a, 1] * B[1, b] + A[a, 2] * B[2, b]


def _relative_log(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    """Rotation vectors of ``A[i] @ B[i]^T`` into ``out[i]`` (N, 3)."""
    M = np.empty((3, 3))
    for i in range(A.shape[0]):
        _relative(A[i], B[i], M, out[i])


def _relative(A: np.ndarray, B: np.ndarray, M: np.ndarray, out: np.ndarray) -> None:
    """The rotation vector of ``A @ B^T`` ((3, 3) each) into ``out`` (3,) (``M`` scratch
    (3, 3))."""
    for a in range(3):
        for b in range(3):
            M[a, b] = A[a, 0] * B[b, 0] + A[a, 1] * B[b, 1] + A[a, 2] * B[b, 2]
    _log(M, out)


#: the rotation helpers, inlined into every loop that calls them (here, the residual
#: and the sweep): a call costs as much as their arithmetic
INLINE = ("_log", "_expm", "_times", "_relative", "_series")
_turned_loop = compiled.Lazy(globals(), ("_expm", "_series", "_times"), _turned, INLINE)
_relative_log_loop = compiled.Lazy(
    globals(), ("_log", "_series", "_relative"), _relative_log, INLINE
)


def turned(w: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``expm_so3(w) @ R`` (..., 3, 3) for rotation vectors (..., 3), compiled."""
    out = np.empty(R.shape)
    _turned_loop(
        np.ascontiguousarray(w, float).reshape(-1, 3),
        np.ascontiguousarray(R, float).reshape(-1, 3, 3),
        out.reshape(-1, 3, 3),
    )
    return out


def relative_log(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of ``A @ B^T`` for matrices (..., 3, 3), compiled."""
    out = np.empty(A.shape[:-1])
    _relative_log_loop(
        np.ascontiguousarray(A, float).reshape(-1, 3, 3),
        np.ascontiguousarray(B, float).reshape(-1, 3, 3),
        out.reshape(-1, 3),
    )
    return out


__all__ = ["AVAILABLE", "relative_log", "turned"]
