"""Batched 3-D rotation helpers (rotation vectors in radians, any leading shape)."""

from __future__ import annotations

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (broadcasting; quicker than np.cross for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a * b).sum(-1)


def rotate(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R @ v`` over leading axes: R (..., 3, 3), v (..., 3)."""
    return np.matmul(R, v[..., None])[..., 0]


def expm_so3(w: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors ``w`` (..., 3) (Rodrigues).

    ``R = cos(t) I + sin(t)/t [w]x + (1 - cos(t))/t^2 w w^T`` with ``t = |w|``.
    """
    w = np.asarray(w, dtype=float)
    th2 = (w * w).sum(-1)
    small = th2 < 1e-12
    th = np.sqrt(np.where(small, 1.0, th2))
    A = np.where(small, 1.0 - th2 / 6.0, np.sin(th) / th)
    B = np.where(small, 0.5 - th2 / 24.0, (1.0 - np.cos(th)) / (th * th))
    C = 1.0 - B * th2  # = cos(t)
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    Ax, Ay, Az = A * x, A * y, A * z
    Bxy, Bxz, Byz = B * x * y, B * x * z, B * y * z
    R = np.empty(w.shape[:-1] + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 0, 2] = C + B * x * x, Bxy - Az, Bxz + Ay
    R[..., 1, 0], R[..., 1, 1], R[..., 1, 2] = Bxy + Az, C + B * y * y, Byz - Ax
    R[..., 2, 0], R[..., 2, 1], R[..., 2, 2] = Bxz - Ay, Byz + Ax, C + B * z * z
    return R


def log_so3(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of rotation matrices (angles below pi)."""
    vee = np.empty(R.shape[:-1])
    vee[..., 0] = R[..., 2, 1] - R[..., 1, 2]
    vee[..., 1] = R[..., 0, 2] - R[..., 2, 0]
    vee[..., 2] = R[..., 1, 0] - R[..., 0, 1]
    s = 0.5 * np.sqrt((vee * vee).sum(-1))
    c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    th = np.arctan2(s, c)
    small = s < 1e-8
    f = np.where(small, 0.5 + th * th / 12.0, th / (2.0 * np.where(small, 1.0, s)))
    return f[..., None] * vee
