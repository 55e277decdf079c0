"""Compiled RK4 loop of the minibus ride model (numba), design by design.

:meth:`suspenv.models.minibus.ride_model.RideModel.rhs` evaluates the state derivative
of a whole batch with numpy (one call per RK4 stage, the batch on the last axis); on
the small batches a diagnosis fits (one to a dozen designs) the numpy call overhead
dominates. This module runs the same scheme compiled: for each design in turn, the
fixed-step RK4 over the half-step road grid with the same element laws (linear
springs and tyre dampers, the two-stage rear leaf, the asymmetric digressive dampers,
tyre lift-off, and the effects: bump/rebound stops, smooth Coulomb damper friction,
Dahl leaf friction; the effects' laws are :mod:`suspenv.models.effects.laws`' float
forms, the numpy loop's own). The sums run in another order than numpy's matrix
products, so the outputs agree with the numpy loop to rounding
(``tests/test_ride_kernel.py``).
Frames, units and signs are those of :mod:`suspenv.models.minibus.ride_model`.

Effects are passed as rows of float arrays (:func:`pack_effects`); their parameters
are checked once there, never inside the loop. Without numba (an unusual platform),
:data:`AVAILABLE` is False and the numpy loop runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from suspenv.core import compiled
from suspenv.core.errors import ValidationError
from suspenv.models.effects.effect import Effect
from suspenv.models.effects.laws import FLOATS, JITABLE

#: numba is there: the compiled loop can run (compiled at the first call)
AVAILABLE = compiled.AVAILABLE


def _column(value: object, n: int, name: str) -> np.ndarray:
    """An effect parameter as an (n,) float column (a scalar or one value per design)."""
    arr = np.broadcast_to(np.asarray(value, dtype=float).reshape(-1), (n,))
    if not np.all(np.isfinite(arr)):
        raise ValidationError(f"ride effect parameter `{name}` must be finite, but got {arr}")
    return np.ascontiguousarray(arr)


def _require(ok: bool, rule: str, value: object) -> None:
    if not ok:
        raise ValidationError(f"`{rule}` must hold, but got {value}")


def pack_effects(
    effects: Sequence[Effect], n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Check the effects' parameters once and pack them for :func:`run`.

    Returns ``stop_col`` (n_stop,) suspension column 0..3 of each stop's first
    wheel (the stop acts on that column and the next: one axle),
    ``stop_par`` (n_stop, n, 4): gap [m], k_stop [N/m^p], p, sign (+1 bump, -1 rebound);
    ``fric_col`` (n_fric,), ``fric_par`` (n_fric, n, 2): f_c [N], v_eps [m/s];
    ``hyst`` (n, 2) Dahl sigma [N/m], f_c [N] of the rear leaves (empty: no Dahl).
    """
    stop_col, stop_par, fric_col, fric_par = [], [], [], []
    hyst = np.zeros((0, 2))
    for e in effects:
        col = 0 if e.location.startswith("front") else 2
        p = e.params
        if e.kind in ("bump_stop", "rebound_stop"):
            gap, k, ex = (_column(p[k], n, k) for k in ("gap", "k_stop", "p"))
            _require(bool(np.all(gap >= 0)), "gap >= 0", gap)
            _require(bool(np.all(k >= 0)), "k_stop >= 0", k)
            _require(bool(np.all(ex >= 1)), "p >= 1", ex)
            sign = np.full(n, 1.0 if e.kind == "bump_stop" else -1.0)
            stop_col.append(col)
            stop_par.append(np.stack([gap, k, ex, sign], axis=1))
        elif e.kind == "coulomb_friction":
            f_c, v_eps = _column(p["f_c"], n, "f_c"), _column(p["v_eps"], n, "v_eps")
            _require(bool(np.all(v_eps > 0)), "v_eps > 0", v_eps)
            fric_col.append(col)
            fric_par.append(np.stack([f_c, v_eps], axis=1))
        elif e.kind == "dahl_hysteresis":
            hyst = np.stack([_column(p["sigma"], n, "sigma"), _column(p["f_c"], n, "f_c")], 1)
        else:
            raise ValidationError(f"the compiled ride loop has no law for effect {e.kind!r}")
    return (
        np.asarray(stop_col, np.int64),
        np.ascontiguousarray(np.asarray(stop_par, float).reshape(len(stop_col), n, 4)),
        np.asarray(fric_col, np.int64),
        np.ascontiguousarray(np.asarray(fric_par, float).reshape(len(fric_col), n, 2)),
        np.ascontiguousarray(hyst),
    )


def _forces(
    x: np.ndarray,
    r: np.ndarray,
    i: int,
    nq: int,
    npos: int,
    pv: np.ndarray,
    kel: np.ndarray,
    leaf: np.ndarray,
    damp: np.ndarray,
    knees: np.ndarray,
    f0: np.ndarray,
    linear: bool,
    stop_col: np.ndarray,
    stop_par: np.ndarray,
    fric_col: np.ndarray,
    fric_par: np.ndarray,
    e: np.ndarray,
    f: np.ndarray,
) -> None:
    """Element deflections ``e`` and forces ``f`` of design ``i`` at state ``x``."""
    ne = pv.shape[0]
    for j in range(ne):
        off = 0 if j < npos else nq
        s = 0.0
        for q in range(nq):
            s += pv[j, q] * x[off + q]
        e[j] = s + r[j]
        f[j] = kel[i, j] * e[j]
    if linear:
        for w in range(4):
            f[npos + w] = damp[i, 0, w] * e[npos + w]
        return
    for w in range(2):  # two-stage leaf beyond the helper knee
        f[2 + w] += leaf[i, 0] * max(e[2 + w] - leaf[i, 1], 0.0) - leaf[i, 2]
    for w in range(4):  # asymmetric digressive dampers
        v = e[npos + w]
        vc = min(max(v, knees[1, w]), knees[0, w])
        b = 0 if v > 0 else 2
        f[npos + w] = damp[i, b, w] * vc + damp[i, b + 1, w] * (v - vc)
    for w in range(4):  # tyres cannot pull
        ft = f[6 + w] + f[npos + 4 + w]
        f[6 + w] += max(ft, -f0[i, w]) - ft
    for s_ in range(stop_col.shape[0]):
        gap, k, ex, sign = (
            stop_par[s_, i, 0],
            stop_par[s_, i, 1],
            stop_par[s_, i, 2],
            stop_par[s_, i, 3],
        )
        for w in range(stop_col[s_], stop_col[s_] + 2):
            if sign > 0.0:
                f[w] += FLOATS.bump_stop(e[w], gap, k, ex)
            else:
                f[w] += FLOATS.rebound_stop(e[w], gap, k, ex)
    for s_ in range(fric_col.shape[0]):
        for w in range(fric_col[s_], fric_col[s_] + 2):
            v = e[npos + w]
            f[npos + w] += FLOATS.coulomb_smooth(v, fric_par[s_, i, 0], fric_par[s_, i, 1])


def _rhs(
    x: np.ndarray,
    r: np.ndarray,
    i: int,
    nq: int,
    npos: int,
    pv: np.ndarray,
    bt: np.ndarray,
    kel: np.ndarray,
    minv: np.ndarray,
    m12: np.ndarray,
    leaf: np.ndarray,
    damp: np.ndarray,
    knees: np.ndarray,
    f0: np.ndarray,
    linear: bool,
    stop_col: np.ndarray,
    stop_par: np.ndarray,
    fric_col: np.ndarray,
    fric_par: np.ndarray,
    hyst: np.ndarray,
    e: np.ndarray,
    f: np.ndarray,
    out: np.ndarray,
) -> None:
    """State derivative ``out`` of design ``i`` at state ``x`` (the numpy ``rhs``'s laws)."""
    _forces(
        x,
        r,
        i,
        nq,
        npos,
        pv,
        kel,
        leaf,
        damp,
        knees,
        f0,
        linear,
        stop_col,
        stop_par,
        fric_col,
        fric_par,
        e,
        f,
    )
    if hyst.shape[0] > 0:
        for w in range(2):  # Dahl leaf friction: its force z, state derivative
            z = x[2 * nq + w]
            f[2 + w] += z
            v = 0.0
            for q in range(nq):
                v += pv[2 + w, q] * x[nq + q]
            out[2 * nq + w] = FLOATS.dahl_dzdt(z, v, hyst[i, 0], hyst[i, 1])
    for q in range(nq):
        s = 0.0
        for j in range(bt.shape[1]):
            s += bt[q, j] * f[j]
        out[nq + q] = s
    q0, q1 = out[nq], out[nq + 1]
    for q in range(nq):
        out[nq + q] *= minv[i, q]
        out[q] = x[nq + q]
    out[nq] += m12[i] * q1
    out[nq + 1] += m12[i] * q0


def _run(
    road: np.ndarray,
    dt: float,
    discard: int,
    nq: int,
    npos: int,
    pv: np.ndarray,
    bt: np.ndarray,
    kel: np.ndarray,
    minv: np.ndarray,
    m12: np.ndarray,
    leaf: np.ndarray,
    damp: np.ndarray,
    knees: np.ndarray,
    f0: np.ndarray,
    linear: bool,
    stop_col: np.ndarray,
    stop_par: np.ndarray,
    fric_col: np.ndarray,
    fric_par: np.ndarray,
    hyst: np.ndarray,
    rec_rows: np.ndarray,
    rec: np.ndarray,
    states: np.ndarray,
    final: np.ndarray,
) -> None:
    """RK4 from rest for every design; accelerations ``rec`` (n, rows, N) at each step
    start (the first stage), full states (n, S, N) when ``states`` has a time axis, the
    last state ``final`` (n, S). A design whose state stops being finite is left NaN
    from there on."""
    n, S = final.shape
    ne = pv.shape[0]
    n_steps = (road.shape[0] - 1) // 2
    keep_states = states.shape[2] > 0
    x, tmp = np.zeros(S), np.zeros(S)
    K = np.zeros((4, S))  # the four RK4 stages' derivatives
    e, f = np.zeros(ne), np.zeros(ne)
    h6 = dt / 6
    # stage st starts from x + step[st] * K[st - 1] at road sample 2k + (st + 1) // 2
    step = np.array([0.0, dt / 2, dt / 2, dt])
    for i in range(n):
        x[:] = 0.0
        for k in range(n_steps):
            for st in range(4):
                for s in range(S):
                    tmp[s] = x[s] if st == 0 else x[s] + step[st] * K[st - 1, s]
                _rhs(
                    tmp,
                    road[2 * k + (st + 1) // 2],
                    i,
                    nq,
                    npos,
                    pv,
                    bt,
                    kel,
                    minv,
                    m12,
                    leaf,
                    damp,
                    knees,
                    f0,
                    linear,
                    stop_col,
                    stop_par,
                    fric_col,
                    fric_par,
                    hyst,
                    e,
                    f,
                    K[st],
                )
            j = k - discard
            if j >= 0:
                for m in range(rec_rows.shape[0]):
                    rec[i, m, j] = K[0, rec_rows[m]]
                if keep_states:
                    states[i, :, j] = x
            finite = True
            for s in range(S):
                x[s] += h6 * (K[0, s] + 2.0 * (K[1, s] + K[2, s]) + K[3, s])
                finite = finite and math.isfinite(x[s])
            if not finite:
                x[:] = np.nan
                for jj in range(max(j + 1, 0), rec.shape[2]):
                    rec[i, :, jj] = np.nan
                    if keep_states:
                        states[i, :, jj] = np.nan
                break
        final[i] = x


#: :func:`_run`, compiled at its first call (numba's cache keeps it for later
#: processes); without numba, :func:`_run` itself
run = compiled.Lazy(globals(), ("_forces", "_rhs"), _run, jitable=JITABLE)
