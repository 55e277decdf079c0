"""Batched 3-D rotation helpers (rotation vectors in radians, any leading shape); the
rotation updates of the Newton steps run matrix by matrix (see ``ROWS_LAST``)."""

from __future__ import annotations

import numpy as np

from suspenv.models.mcpherson import rotation_kernel


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (broadcasting; quicker than np.cross for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(a.shape if a.shape == b.shape else np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a * b).sum(-1)


def rotate(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R @ v`` over leading axes: R (..., 3, 3), v (..., 3)."""
    return np.matmul(R, v[..., None])[..., 0]


def _rodrigues_coefficients(th2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``sin(t)/t``, ``(1 - cos(t))/t^2`` and ``cos(t)`` of rotation angles ``t`` given as
    ``th2 = t^2`` [rad^2] (series in ``t^2`` below ``t = 1e-6`` rad)."""
    small = th2 < 1e-12
    if small.any():
        th = np.sqrt(np.where(small, 1.0, th2))
        A = np.where(small, 1.0 - th2 / 6.0, np.sin(th) / th)
        B = np.where(small, 0.5 - th2 / 24.0, (1.0 - np.cos(th)) / (th * th))
    else:
        th = np.sqrt(th2)
        A = np.sin(th) / th
        B = (1.0 - np.cos(th)) / (th * th)
    return A, B, 1.0 - B * th2


def expm_so3(w: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors ``w`` (..., 3) (Rodrigues).

    ``R = cos(t) I + sin(t)/t [w]x + (1 - cos(t))/t^2 w w^T`` with ``t = |w|`` (series
    in ``t^2`` below ``t = 1e-6`` rad).
    """
    w = np.asarray(w, dtype=float)
    th2 = (w * w).sum(-1)
    A, B, C = _rodrigues_coefficients(th2)
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    Ax, Ay, Az = A * x, A * y, A * z
    Bx = B * x
    Bxy, Bxz, Byz = Bx * y, Bx * z, B * y * z
    R = np.empty(w.shape[:-1] + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 0, 2] = C + Bx * x, Bxy - Az, Bxz + Ay
    R[..., 1, 0], R[..., 1, 1], R[..., 1, 2] = Bxy + Az, C + B * y * y, Byz - Ax
    R[..., 2, 0], R[..., 2, 1], R[..., 2, 2] = Bxz - Ay, Byz + Ax, C + B * z * z
    return R


#: flat (row-major) indices of the entries of ``[w]x`` equal to +w and -w (x, y, z)
_SKEW_PLUS = np.array([7, 2, 3])
_SKEW_MINUS = np.array([5, 6, 1])


def _log_factor(s: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``t / (2 sin(t))`` of rotation angles ``t = atan2(s, c)`` from ``s = sin(t)`` and
    ``c = cos(t)``, the factor from the skew part ``vee`` to the rotation vector (series
    in ``t^2`` below ``sin(t) = 1e-8``)."""
    th = np.arctan2(s, c)
    small = s < 1e-8
    if small.any():
        return np.where(small, 0.5 + th * th / 12.0, th / (2.0 * np.where(small, 1.0, s)))
    return th / (2.0 * s)


def log_so3(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of rotation matrices (angles below pi)."""
    flat = R.reshape(R.shape[:-2] + (9,))
    vee = flat[..., _SKEW_PLUS] - flat[..., _SKEW_MINUS]
    s = 0.5 * np.sqrt((vee * vee).sum(-1))
    c = 0.5 * (flat[..., 0] + flat[..., 4] + flat[..., 8] - 1.0)
    return _log_factor(s, c)[..., None] * vee


#: :func:`relative_log` and :func:`turned` run the compiled loops of
#: :mod:`.rotation_kernel` (the same formulas matrix by matrix; plain Python without
#: numba); False: stacked matrix products, the reference path of the speed benchmark's
#: baseline
ROWS_LAST = True


def relative_log(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of ``A B^T`` for rotation matrices A, B (..., 3, 3) of
    the same shape (``log_so3(A @ swapaxes(B))``, matrix by matrix)."""
    if not ROWS_LAST:
        return log_so3(np.matmul(A, np.swapaxes(B, -1, -2)))
    return rotation_kernel.relative_log(A, B)


def turned(w: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``expm_so3(w) @ R`` (..., 3, 3) for rotation vectors ``w`` (..., 3) and matrices
    ``R`` (..., 3, 3) of the same leading shape (matrix by matrix)."""
    if not ROWS_LAST:
        return np.matmul(expm_so3(w), R)
    return rotation_kernel.turned(w, R)
