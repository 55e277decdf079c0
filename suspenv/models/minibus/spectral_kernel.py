"""Compiled loops of the spectral ride method (numba), design by design.

For one design the numpy forms of a spectral ride pass are many small array calls;
these loops run the same arithmetic compiled:

- :func:`mean_square`: the frequency sums of :func:`suspenv.metrics.ride.
  _split_mean_square`, from the modal form of the ride model's two halves (real
  second-order terms per row) to weighted mean squares (frequencies in rad/s,
  responses per m of axle input, weights as :func:`suspenv.metrics.ride.
  _split_grid_values`); the sums run in another order than numpy's matrix products,
  so the values agree to rounding (``tests/test_ride_spectral.py``: split path
  against the full model);
- :func:`damper_leaf_rates`: the equivalent-linear damper and rear-leaf rates of
  :meth:`suspenv.models.minibus.linearisation.ElementLinearisation.rates` for a
  model without rear end stops (``tests/test_minibus_ride_elements.py``: against the
  numpy form). The standard normal CDF as scipy's ``ndtr`` (cephes) forms it.
"""

from __future__ import annotations

import math

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


def _ndtr(a: float) -> float:
    """Standard normal CDF (-), as cephes' ``ndtr``: erf near 0, erfc in the tails."""
    x = a * math.sqrt(0.5)
    if abs(x) < math.sqrt(0.5):
        return 0.5 + 0.5 * math.erf(x)
    y = 0.5 * math.erfc(abs(x))
    return 1.0 - y if x > 0 else y


def _excess(a: float) -> float:
    """``E[max(t - a, 0)]`` (-) for a standard normal t (as ``linearisation._excess``)."""
    return math.exp(-0.5 * a * a) / math.sqrt(2.0 * math.pi) - a * _ndtr(-a)


def _damper_leaf_rates(
    sv: np.ndarray,
    sd: np.ndarray,
    damp: np.ndarray,
    knee: np.ndarray,
    leaf: np.ndarray,
    passes: int,
    out: np.ndarray,
) -> None:
    """Damper coefficients (N s/m) and rear leaf rates (N/m) into ``out`` (n, 6) from
    the RMS damper velocities ``sv`` (n, 4; m/s) and leaf deflections ``sd`` (n, 2;
    m), both > 0: ``damp`` (n, 4, 4) slopes (bump low, bump high, rebound low, rebound
    high) per damper, ``knee`` (4, 2) knees (bump, rebound > 0; m/s), ``leaf`` (n, 2, 3)
    per leaf (primary rate K_1 (N/m), extra rate dk (N/m), knee e_k (m) from rest);
    the leaf's mean deflection by ``passes`` Newton steps (laws and steps of
    :class:`suspenv.models.minibus.linearisation.ElementLinearisation`)."""
    c0 = 1.0 / math.sqrt(2.0 * math.pi)
    for i in range(sv.shape[0]):
        for j in range(4):
            s = sv[i, j]
            pb, pr = _ndtr(knee[j, 0] / s), _ndtr(knee[j, 1] / s)
            bl, bh, rl, rh = damp[i, j, 0], damp[i, j, 1], damp[i, j, 2], damp[i, j, 3]
            out[i, j] = bl * (pb - 0.5) + bh * (1 - pb) + rl * (pr - 0.5) + rh * (1 - pr)
        for side in range(2):
            j = 2 + side
            s, d = sv[i, j], sd[i, side]
            k1, dk, thr = leaf[i, side, 0], leaf[i, side, 1], leaf[i, side, 2]
            tb, tr = s * _excess(knee[j, 0] / s), s * _excess(knee[j, 1] / s)
            bump = damp[i, j, 0] * (s * c0 - tb) + damp[i, j, 1] * tb
            mean_force = bump - (damp[i, j, 2] * (s * c0 - tr) + damp[i, j, 3] * tr)
            rhs = -mean_force + dk * max(-thr, 0.0)
            m = (rhs - dk * d * _excess(thr / d)) / k1
            for _ in range(passes):
                a = (thr - m) / d
                f = k1 * m + dk * d * _excess(a) - rhs
                m = m - f / (k1 + dk * (1.0 - _ndtr(a)))
            out[i, j + 2] = k1 + dk * (1.0 - _ndtr((thr - m) / d))


#: :func:`_mean_square` and :func:`_damper_leaf_rates`, built ahead of time
#: (:mod:`suspenv.core.compiled`)
mean_square = compiled.Lazy(globals(), (), _mean_square)
damper_leaf_rates = compiled.Lazy(globals(), ("_ndtr", "_excess"), _damper_leaf_rates)
