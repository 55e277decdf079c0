"""The 40 K&C objectives of swept states, design by design (numba).

The compiled form of :func:`suspenv.metrics.knc.objectives` for the states of the
rig's two-leg sweep kept at the fit window
(:meth:`~suspenv.models.mcpherson.solver.AxleSolver.two_leg_sweep`): per design and
travel test, the channels the objectives read (those of
:meth:`~suspenv.models.mcpherson.solver.AxleSolver.outputs`), the curves of
:func:`suspenv.metrics.knc._curves` and the quadratic fits of
:func:`suspenv.metrics.knc.quadratic_fit`, the same formulas in the same order. Both
branches of a two-leg loop visit each grid point in the same state, so a branch's number
is the loop's (the numpy path's mean of two equal numbers). ``tests/test_knc_kernel.py``
compares it with the numpy path. Units and signs: those of :mod:`suspenv.metrics.knc`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from suspenv.core import compiled
from suspenv.models.mcpherson.params import SIDE_SIGN

#: the curves of :func:`suspenv.metrics.knc._curves`, in the kernel's order
CURVES = (
    "toe", "camber", "caster", "hub_lateral", "hub_fore_aft", "contact_lateral",
    "contact_fore_aft", "tyre_fz", "wheel", "pad", "roll", "half_force_difference",
    "half_travel_difference", "roll_moment", "roll_axle",
)  # fmt: skip
#: reduction -> the fit's number it picks (value, slope, curvature)
PICK = {"value": 0, "gradient": 1, "rate": 1, "rate_gradient": 2}
#: degrees per radian: :data:`suspenv.measurements.knc.RAD2DEG`, spelt out here because
#: the build environment loads this module with numpy and numba alone
RAD2DEG = 180.0 / np.pi


def objective_table(objectives: Sequence[Any], tests: Sequence[str]) -> np.ndarray:
    """The kernel's table (m, 5) of objectives (:class:`~suspenv.metrics.knc.KCObjective`):
    test index in ``tests``, curve and abscissa indices in :data:`CURVES`, picked number
    (:data:`PICK`), 1 when only the moving (left) wheel counts (single wheel travel)."""
    return np.array(
        [
            [
                tests.index(o.test),
                CURVES.index(o.curve),
                CURVES.index(o.x),
                PICK[o.reduce],
                int(o.test == "single"),
            ]  # fmt: skip
            for o in objectives
        ],
        dtype=np.int64,
    )


def _channels(r, R, pads, s0, Rw, kt, kB, t, d, ch) -> None:
    """Channels (10, Q, 2) of design ``d`` in test ``t`` at the kept grid points into
    ``ch``: wheel centre x, y, z, contact point x, y [m], tyre force [N], pad height
    [m], toe, camber, caster [rad] (:meth:`AxleSolver.outputs`)."""
    s = np.empty(3)
    dn = np.empty(3)
    k = np.empty(3)
    for q in range(r.shape[1]):
        for side in range(2):
            sg = SIDE_SIGN[side]
            R1 = R[t, q, d, side, 1]
            wc = r[t, q, d, side, 1]
            top = r[t, q, d, side, 2]
            for a in range(3):
                s[a] = R1[a, 0] * s0[d, side, 0] + R1[a, 1] * s0[d, side, 1]
                s[a] += R1[a, 2] * s0[d, side, 2]
                k[a] = R1[a, 0] * kB[d, side, 0] + R1[a, 1] * kB[d, side, 1]
                k[a] = top[a] - (wc[a] + (k[a] + R1[a, 2] * kB[d, side, 2]))
            for a in range(3):
                dn[a] = s[2] * s[a]
            dn[2] -= 1.0
            length = math.sqrt(dn[0] * dn[0] + dn[1] * dn[1] + dn[2] * dn[2])
            pad = pads[t, q, d, side]
            ch[0, q, side], ch[1, q, side], ch[2, q, side] = wc[0], wc[1], wc[2]
            ch[3, q, side] = wc[0] + Rw[d, side] * (dn[0] / length)
            ch[4, q, side] = wc[1] + Rw[d, side] * (dn[1] / length)
            ch[5, q, side] = kt[d, side] * (pad - (wc[2] + Rw[d, side] * (dn[2] / length)))
            ch[6, q, side] = pad
            hx, hy = sg * s[1], sg * -s[0]
            hn = math.sqrt(hx * hx + hy * hy)
            ch[7, q, side] = -sg * math.atan2(hy / hn, hx / hn)
            ch[8, q, side] = -math.asin(min(max(s[2], -1.0), 1.0))
            kl = math.sqrt(k[0] * k[0] + k[1] * k[1] + k[2] * k[2])
            ch[9, q, side] = math.atan2(-(k[0] / kl), k[2] / kl)


def _curves(ch, st, cv) -> None:
    """The curves (15, Q, 2) of :data:`CURVES` from the channels ``ch`` (:func:`_channels`),
    the design position at index ``st``, into ``cv`` (:func:`suspenv.metrics.knc._curves`)."""
    Q = ch.shape[1]
    track = ch[1, st, 0] - ch[1, st, 1]
    t_cp = ch[4, st, 0] - ch[4, st, 1]
    phi_st = math.atan((ch[2, st, 0] - ch[2, st, 1]) / track) * RAD2DEG
    for q in range(Q):
        phi = math.atan((ch[2, q, 0] - ch[2, q, 1]) / track) * RAD2DEG - phi_st
        for side in range(2):
            sg = SIDE_SIGN[side]
            cv[0, q, side] = ch[7, q, side] * RAD2DEG
            cv[1, q, side] = ch[8, q, side] * RAD2DEG
            cv[2, q, side] = ch[9, q, side] * RAD2DEG
            cv[3, q, side] = ch[1, q, side] * sg * 1e3
            cv[4, q, side] = ch[0, q, side] * 1e3
            cv[5, q, side] = ch[4, q, side] * sg * 1e3
            cv[6, q, side] = ch[3, q, side] * 1e3
            cv[7, q, side] = ch[5, q, side]
            cv[8, q, side] = (ch[2, q, side] - ch[2, st, side]) * 1e3
            cv[9, q, side] = (ch[6, q, side] - ch[6, st, side]) * 1e3
            cv[10, q, side] = phi * sg
        half_force = 0.5 * (ch[5, q, 0] - ch[5, q, 1])
        for side in range(2):
            cv[11, q, side] = half_force
            cv[12, q, side] = 0.5 * (cv[8, q, 0] - cv[8, q, 1])
            cv[13, q, side] = half_force * t_cp
            cv[14, q, side] = phi


def _fit(x: np.ndarray, y: np.ndarray, st: int, pick: int) -> float:
    """The number ``pick`` (value, slope, curvature 2c) at ``x[st]`` of the least-squares
    quadratic through the points (``x``, ``y``) (Q,) (:func:`.knc.quadratic_fit`)."""
    S0 = float(x.size)
    S1 = S2 = S3 = S4 = T0 = T1 = T2 = 0.0
    lo, hi = math.inf, -math.inf
    for q in range(x.size):
        xs = x[q] - x[st]
        x2 = xs * xs
        S1 += xs
        S2 += x2
        S3 += x2 * xs
        S4 += x2 * x2
        T0 += y[q]
        T1 += xs * y[q]
        T2 += x2 * y[q]
        lo, hi = min(lo, xs), max(hi, xs)
    C00, C01, C02 = S2 * S4 - S3 * S3, S2 * S3 - S1 * S4, S1 * S3 - S2 * S2
    C11, C12, C22 = S0 * S4 - S2 * S2, S1 * S2 - S0 * S3, S0 * S2 - S1 * S1
    det = S0 * C00 + S1 * C01 + S2 * C02
    spread = hi - lo
    finite = abs(det) < math.inf and abs(T0) < math.inf and abs(T1) < math.inf
    if not (finite and abs(T2) < math.inf and spread > 0):
        return math.nan
    if not abs(det) > 1e-12 * max(spread, 1e-300) ** 6:
        return math.nan
    inv = 1.0 / det
    if pick == 0:
        return (C00 * T0 + C01 * T1 + C02 * T2) * inv
    if pick == 1:
        return (C01 * T0 + C11 * T1 + C12 * T2) * inv
    return 2.0 * ((C02 * T0 + C12 * T1 + C22 * T2) * inv)


def _objectives(
    r: np.ndarray,
    R: np.ndarray,
    pads: np.ndarray,
    s0: np.ndarray,
    Rw: np.ndarray,
    kt: np.ndarray,
    kB: np.ndarray,
    table: np.ndarray,
    F: np.ndarray,
) -> None:
    """The objectives (n, m) of every design into ``F``.

    States at the Q kept grid points of every travel test (T, Q, n, ...): positions
    ``r`` (T, Q, n, 2, 4, 3) [m], rotations ``R`` (T, Q, n, 2, 4, 3, 3), pad heights
    ``pads`` (T, Q, n, 2) [m]; per design and side: the spin axis at design ``s0`` (n,
    2, 3), the tyre radius ``Rw`` (n, 2) [m] and rate ``kt`` (n, 2) [N/m], the
    knuckle's lower strut point ``kB`` (n, 2, 3) [m] (body-fixed); ``table`` (m, 5)
    (:func:`objective_table`). The design position is the middle kept point."""
    Q = r.shape[1]
    st = Q // 2
    ch = np.empty((10, Q, 2))
    cv = np.empty((r.shape[0], len(CURVES), Q, 2))
    for d in range(r.shape[2]):
        for t in range(r.shape[0]):
            _channels(r, R, pads, s0, Rw, kt, kB, t, d, ch)
            _curves(ch, st, cv[t])
        for j in range(table.shape[0]):
            t, c, xi, pick, single = table[j]
            left = _fit(cv[t, xi, :, 0], cv[t, c, :, 0], st, pick)
            right = left if single else _fit(cv[t, xi, :, 1], cv[t, c, :, 1], st, pick)
            F[d, j] = (left + right) / 2.0


_HELPERS = ("_channels", "_curves", "_fit")
#: :func:`_objectives`, built ahead of time or compiled at its first call
objectives = compiled.Lazy(globals(), _HELPERS, _objectives)
