"""Compiled frequency sums of the spectral ride method (numba), design by design.

:func:`suspenv.metrics.ride._split_mean_square` turns the modal form of the ride
model's two halves (real second-order terms per row) into weighted mean squares over
a frequency grid. For one design the numpy form is a dozen small array calls per
pass; this loop runs the same sums compiled. The sums run in another order than
numpy's matrix products, so the values agree with the numpy form to rounding
(``tests/test_ride_spectral.py``). Frequencies in rad/s, responses per m of axle
input, weights as :func:`suspenv.metrics.ride._split_grid_values`.
"""

from __future__ import annotations

import numpy as np

from suspenv.core import compiled


def _mean_square(
    q0: np.ndarray,
    q1: np.ndarray,
    coef: np.ndarray,
    w: np.ndarray,
    dr: np.ndarray,
    di: np.ndarray,
    wt: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[i, o, j] = sum_h sum_f wt[f, h J + j] |g_o(f)|^2`` (n designs, p outputs,
    J weight columns per half) over the halves h of design i (rows 2 i + h of ``q0``,
    ``q1`` (2n, d) and ``coef`` (2n, 2p, 2d): rows front outputs then rear outputs,
    columns the constant then the s terms), with ``g = H_front + (dr + i di) H_rear``
    and ``H_o = sum_k (coef[o, k] + s coef[o, d + k]) / (s^2 - q1[k] s + q0[k])`` at
    ``s = i w`` (w (Nf,) rad/s)."""
    rows, d = q0.shape
    p = coef.shape[1] // 2
    n_w = out.shape[2]
    er, ei = np.empty(d), np.empty(d)
    out[:] = 0.0
    for r in range(rows):
        i, off = r // 2, (r % 2) * n_w
        for f in range(w.size):
            wf = w[f]
            for k in range(d):
                # E = 1/(q0 - w^2 - i q1 w) = (q0 - w^2 + i q1 w)/den
                a, b = q0[r, k] - wf * wf, q1[r, k] * wf
                den = a * a + b * b
                er[k], ei[k] = a / den, b / den
            for o in range(p):
                g0r = g0i = g1r = g1i = 0.0
                for k in range(d):
                    # H = E a + i w E b
                    a0, b0 = coef[r, o, k], coef[r, o, d + k] * wf
                    a1, b1 = coef[r, p + o, k], coef[r, p + o, d + k] * wf
                    g0r += a0 * er[k] - b0 * ei[k]
                    g0i += a0 * ei[k] + b0 * er[k]
                    g1r += a1 * er[k] - b1 * ei[k]
                    g1i += a1 * ei[k] + b1 * er[k]
                gr = g0r + dr[f] * g1r - di[f] * g1i
                gi = g0i + dr[f] * g1i + di[f] * g1r
                g2 = gr * gr + gi * gi
                for j in range(n_w):
                    out[i, o, j] += g2 * wt[f, off + j]


#: :func:`_mean_square`, built ahead of time (:mod:`suspenv.core.compiled`)
mean_square = compiled.Lazy(globals(), (), _mean_square)
