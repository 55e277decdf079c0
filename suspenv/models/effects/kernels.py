"""Compiled sample loops of the effect elements (numba), row by row.

* :func:`recurrence`: ``z[k+1] = a[k] + b[k] z[k]``, the exact steps of the Dahl,
  Maxwell, LuGre and sensor-lag elements (``_util.linear_recurrence``);
* :func:`bouc_wen_rows`: the exact n = 1 Bouc-Wen path.

The product runs only these loops (as plain Python where numba is missing). Their
reference is the same arithmetic written as float loops over lists,
``tests/effects_reference.py`` (``tests/test_effect_kernels.py`` compares them).

Bouc-Wen: with ``w = sign(dx) z`` and the travel ``u = |dx|`` of each segment,
``dw/du = A - (beta + gamma) w`` above zero and ``A - (beta - gamma) w`` below, each
segment at most two exact exponential relaxations. ``z`` is the dimensionless hysteretic
state; ``dx`` [m] the displacement increments, ``A`` [1/m]-scaled as in the Bouc-Wen module.
"""

from __future__ import annotations

import math

import numpy as np

from suspenv.core import compiled


def _relax(w0: float, a: float, lam: float, u: float) -> float:
    """Exact solution of ``dw/du = a - lam w`` after travel ``u`` (``lam`` may be 0)."""
    if abs(lam * u) < 1e-12:
        return w0 + (a - lam * w0) * u
    return a / lam + (w0 - a / lam) * math.exp(-lam * u)


def _rows(
    dx: np.ndarray,
    a: np.ndarray,
    beta: np.ndarray,
    gamma: np.ndarray,
    z0: np.ndarray,
    out: np.ndarray,
) -> None:
    """States ``out`` (R, T) of the rows of increments ``dx`` (R, T - 1) from ``z0`` (R,)."""
    for r in range(dx.shape[0]):
        ar = a[r]
        lam_pos, lam_neg = beta[r] + gamma[r], beta[r] - gamma[r]
        z = z0[r]
        out[r, 0] = z
        for k in range(dx.shape[1]):
            d = dx[r, k]
            if d == 0.0:
                out[r, k + 1] = z
                continue
            s = 1.0 if d > 0 else -1.0
            u = abs(d)
            w = s * z
            if w < 0.0:
                if abs(lam_neg) < 1e-12:
                    u0 = -w / ar
                else:
                    w_inf = ar / lam_neg
                    gap = w_inf - w
                    ratio = w_inf / gap if gap != 0.0 else -1.0
                    u0 = -math.log(ratio) / lam_neg if ratio > 0.0 else math.inf
                # within the lower regime, or across zero into the upper one
                w = _relax(w, ar, lam_neg, u) if u0 >= u else _relax(0.0, ar, lam_pos, u - u0)
            else:
                w = _relax(w, ar, lam_pos, u)
            z = s * w
            out[r, k + 1] = z


def _recurrence(a: np.ndarray, b: np.ndarray, z0: np.ndarray, out: np.ndarray) -> None:
    """``out[r, k + 1] = a[r, k] + b[r, k] * out[r, k]`` from ``out[r, 0] = z0[r]``."""
    for r in range(a.shape[0]):
        z = z0[r]
        out[r, 0] = z
        for k in range(a.shape[1]):
            z = a[r, k] + b[r, k] * z
            out[r, k + 1] = z


#: :func:`_rows` compiled: ``(dx (R, T-1), a, beta, gamma, z0 (R,), out (R, T))``
bouc_wen_rows = compiled.Lazy(globals(), ("_relax",), _rows)
#: :func:`_recurrence` compiled: ``(a (R, T-1), b (R, T-1), z0 (R,), out (R, T))``
recurrence = compiled.Lazy(globals(), (), _recurrence)
