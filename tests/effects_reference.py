"""Plain-Python loops of the effect elements (tests only): the references of the compiled
loops of :mod:`suspenv.models.effects.kernels`.

* :func:`bouc_wen_row`: the exact n = 1 Bouc-Wen path of one row, over Python floats and
  lists (the scheme of ``hysteresis.bouc_wen_path``: with ``w = sign(dx) z`` and the
  travel ``u = |dx|`` of a segment, ``dw/du = A - (beta + gamma) w`` for ``w >= 0`` and
  ``A - (beta - gamma) w`` for ``w < 0``, each segment at most two exact exponential
  relaxations);
* :func:`recurrence`: ``z[k+1] = a[k] + b[k] z[k]`` row by row (``_util.linear_recurrence``).

Both are checked against closed forms and time integrations in
``test_effects_elements.py`` (through the product, which must equal them:
``test_effect_kernels.py``).
"""

from __future__ import annotations

import math

import numpy as np


def _relax(w0: float, a: float, lam: float, u: float) -> float:
    """Exact solution of ``dw/du = a - lam w`` after travel ``u`` (``lam`` may be 0)."""
    if abs(lam * u) < 1e-12:
        return w0 + (a - lam * w0) * u
    return a / lam + (w0 - a / lam) * math.exp(-lam * u)


def bouc_wen_row(dx: list[float], a: float, beta: float, gamma: float, z: float) -> list[float]:
    """Dimensionless Bouc-Wen states (n = 1) along the increments ``dx`` [m] from ``z``."""
    lam_pos, lam_neg = beta + gamma, beta - gamma
    row = [z]
    for d in dx:
        if d == 0.0:
            row.append(z)
            continue
        s = 1.0 if d > 0 else -1.0
        u = abs(d)
        w = s * z
        if w < 0.0:
            # travel needed to bring w up to zero in the lower regime
            if abs(lam_neg) < 1e-12:
                u0 = -w / a
            else:
                # w_inf: the lower regime's fixed point; a w at or below it (lam_neg
                # < 0) never reaches zero
                w_inf = a / lam_neg
                gap = w_inf - w
                ratio = w_inf / gap if gap != 0.0 else -1.0
                u0 = -math.log(ratio) / lam_neg if ratio > 0.0 else math.inf
            # within the lower regime, or across zero into the upper one
            w = _relax(w, a, lam_neg, u) if u0 >= u else _relax(0.0, a, lam_pos, u - u0)
        else:
            w = _relax(w, a, lam_pos, u)
        z = s * w
        row.append(z)
    return row


def bouc_wen_force_path(
    x: np.ndarray, f_y: float, x_y: np.ndarray, shape: float, z0: np.ndarray
) -> np.ndarray:
    """Engineering-form Bouc-Wen force [N] (n = 1) of the rows of ``x`` (R, T) [m]:
    ``A = 1/x_y``, ``beta = shape/x_y``, ``gamma = (1 - shape)/x_y``, ``F = f_y z``."""
    out = np.empty(x.shape)
    for r in range(x.shape[0]):
        xy = float(x_y[r])
        dx = np.diff(x[r]).tolist()
        out[r] = bouc_wen_row(dx, 1.0 / xy, shape / xy, (1.0 - shape) / xy, float(z0[r]))
    return f_y * out


def recurrence(a: np.ndarray, b: np.ndarray, z0: np.ndarray) -> np.ndarray:
    """``out[r, k + 1] = a[r, k] + b[r, k] out[r, k]`` from ``out[r, 0] = z0[r]``, as a
    float loop per row; ``a`` and ``b`` (R, T - 1), ``z0`` (R,)."""
    out = np.empty((a.shape[0], a.shape[1] + 1))
    for r in range(a.shape[0]):
        z = float(z0[r])
        row = [z]
        for ak, bk in zip(a[r].tolist(), b[r].tolist(), strict=True):
            z = ak + bk * z
            row.append(z)
        out[r] = row
    return out
