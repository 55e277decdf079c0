"""Compiled loops of the minibus handling measures (numba), element by element.

The iterative parts of the handling measures (one design at a time, numpy's call
overhead dominated them): the axle-capacity grid search
(:func:`suspenv.rigs.handling.axle_capacity`), the quasi-steady states on the circle
with their Illinois slip solves (:func:`suspenv.rigs.handling.steady_state_sweep`),
the steady circle's limit search (:func:`suspenv.rigs.handling.steady_circle`) and
the ISO 7401 yaw response's step-time, peak and bandwidth searches
(:func:`suspenv.metrics.handling.yaw_response`). Fixed pass counts: an element's
result never depends on the batch. Against the numpy passes they replaced
(``benchmarks.minibus_speed.numpy_loops``, compared in the tests) the slip solve
starts from a narrower bracket and the step response's search grid takes ``e^(lam
t)`` by repeated products (Newton start values only); both solve to round-off. The
load transfer (:func:`axle_transfer`) and the tyre's factors (:func:`tyre_factors`)
are elementwise helpers that the numpy model calls too. Frames, units and signs of
:mod:`suspenv.models.minibus.handling_model`. Built ahead of time with the package
(:mod:`suspenv.core.compiled`); without numba, the plain Python functions run.
"""

from __future__ import annotations

import cmath
import math
from typing import Any

import numpy as np

from suspenv.core import compiled
from suspenv.models.minibus.spectral_kernel import _solve


def _wheel_force(alpha: float, d: float, b: float, e: float, c: float) -> float:
    """Lateral force (N) of one tyre at slip angle ``alpha`` (rad) from its factors
    (:meth:`LateralTyre.factors`: D N, B 1/rad, E; C = ``pCy1``)."""
    ba = b * alpha
    return d * math.sin(c * math.atan(ba - e * (ba - math.atan(ba))))


def tyre_cornering(fz: Any, k: Any) -> Any:
    """Cornering stiffness Ky [N/rad] at wheel loads ``fz`` [N] of the tyre with
    coefficients ``k`` (:attr:`suspenv.models.minibus.tyre.LateralTyre.coefficients`):
    ``pKy1 fz0 sin(2 atan q) = pKy1 fz0 2 q / (1 + q^2)``, ``q = Fz / (pKy2 fz0)``;
    zero for a lifted wheel. Elementwise: numpy arrays or scalars."""
    q = np.maximum(fz, 0.0) / (k[7] * k[0])
    return k[6] * k[0] * 2.0 * q / (1.0 + q * q)


def tyre_factors(fz: Any, k: Any) -> tuple[Any, Any, Any]:
    """The Magic Formula's load-dependent factors (D [N], B [1/rad], E [-]) at wheel
    loads ``fz`` [N] of the tyre with coefficients ``k`` (as :func:`tyre_cornering`; C
    is pCy1): a lifted wheel (``fz <= 0``) carries nothing. Elementwise: numpy arrays
    or scalars."""
    fz = np.maximum(fz, 0.0)
    dfz = (fz - k[0]) / k[0]
    d = np.maximum(k[2] * (1.0 + k[3] * dfz), 0.05) * fz
    b = tyre_cornering(fz, k) / np.maximum(k[1] * d, 1e-9)
    return d, b, np.minimum(k[4] + k[5] * dfz, 1.0)


def _axle_force(
    alpha: float, d: np.ndarray, b: np.ndarray, e: np.ndarray, j: int, c: float
) -> float:
    """Lateral force (N) of axle ``j``'s two tyres (factors ``d, b, e`` (2, m)) at slip
    angle ``alpha`` (rad)."""
    fa = _wheel_force(alpha, d[0, j], b[0, j], e[0, j], c)
    return fa + _wheel_force(alpha, d[1, j], b[1, j], e[1, j], c)


def _capacity(
    d: np.ndarray, b: np.ndarray, e: np.ndarray, j: int, c: float, grid: np.ndarray
) -> tuple[float, float]:
    """(peak force N, slip angle rad at it) of axle ``j``: the best point of the slip
    grid ``grid`` (evenly spaced from 0), refined by the parabola through it and its
    neighbours (shift within one step); the peak is the larger of the grid's and the
    refined point's force, >= 0."""
    n = grid.shape[0]
    best, f_best = 0, -np.inf
    for g in range(n):
        f = _axle_force(grid[g], d, b, e, j, c)
        if f > f_best:
            best, f_best = g, f
    i = min(max(best, 1), n - 2)
    f0 = _axle_force(grid[i - 1], d, b, e, j, c)
    f1 = _axle_force(grid[i], d, b, e, j, c)
    f2 = _axle_force(grid[i + 1], d, b, e, j, c)
    denom = f0 - 2.0 * f1 + f2
    shift = 0.5 * (f0 - f2) / denom if denom < 0 else 0.0
    shift = min(max(shift, -1.0), 1.0)
    a_peak = grid[i] + shift * (grid[1] - grid[0])
    return max(max(_axle_force(a_peak, d, b, e, j, c), f1), 0.0), a_peak


def _capacity_loop(
    d: np.ndarray, b: np.ndarray, e: np.ndarray, c: float, grid: np.ndarray, out: np.ndarray
) -> None:
    """:func:`_capacity` of every axle (factors ``d, b, e`` (2, m)): ``out`` (2, m) =
    (peak force N, slip angle rad at it)."""
    for j in range(d.shape[1]):
        out[0, j], out[1, j] = _capacity(d, b, e, j, c, grid)


def _slip_bracket(
    d: np.ndarray, b: np.ndarray, e: np.ndarray, j: int, c: float, grid: np.ndarray, f: float
) -> tuple[float, float, float, float, bool]:
    """(lo, residual there, hi, residual there, whether axle ``j`` can carry ``f``) of
    the slip solve: the first point of ``grid`` whose force reaches ``f`` and the one
    before (the axle force is unimodal, so they bracket the root on the rising branch);
    if none does, ``[0, peak slip]`` of :func:`_capacity`, and ``f`` <= its capacity."""
    lo, r_lo = 0.0, -f
    for g in range(1, grid.shape[0]):
        r = _axle_force(grid[g], d, b, e, j, c) - f
        if r >= 0:
            return lo, r_lo, grid[g], r, True
        lo, r_lo = grid[g], r
    cap, hi = _capacity(d, b, e, j, c, grid)
    return 0.0, -f, hi, _axle_force(hi, d, b, e, j, c) - f, cap >= f


def _slip_solve(
    d: np.ndarray,
    b: np.ndarray,
    e: np.ndarray,
    j: int,
    c: float,
    grid: np.ndarray,
    f: float,
    passes: int,
) -> tuple[float, bool]:
    """(slip angle rad, whether it can) at which axle ``j``'s two tyres carry ``f`` N
    on the rising branch: Illinois regula falsi on :func:`_slip_bracket`'s bracket,
    ``passes`` passes; the end with the smaller residual."""
    lo, r_lo, hi, r_hi, can = _slip_bracket(d, b, e, j, c, grid, f)
    side = 0
    for _ in range(passes):
        span = r_hi - r_lo
        mid = (lo * r_hi - hi * r_lo) / span if span > 0 else hi
        r_mid = _axle_force(mid, d, b, e, j, c) - f
        # Illinois: halve the residual of the end that stays twice in a row
        if r_mid < 0:
            if side == -1:
                r_hi = 0.5 * r_hi
            lo, r_lo, side = mid, r_mid, -1
        else:
            if side == 1:
                r_lo = 0.5 * r_lo
            hi, r_hi, side = mid, r_mid, 1
    return (lo if abs(r_lo) < abs(r_hi) else hi), can


def axle_transfer(
    dfz_f: Any, dfz_r: Any, fz_f: Any, fz_r: Any, tf: Any, tr: Any
) -> tuple[Any, Any, Any, Any]:
    """Wheel loads (FL, FR, RL, RR; N, >= 0) from the axles' load transfers ``dfz_f``,
    ``dfz_r`` (N, + to the right wheel) and static wheel loads ``fz_f``, ``fz_r`` (N)
    on tracks ``tf``, ``tr`` (m): an axle cannot transfer more than its static wheel
    load (its inner wheel lifts), the rigid body passes the excess roll moment to the
    other axle, and both lifted is a rollover. Elementwise: numpy arrays
    (:func:`suspenv.models.minibus.handling_model.wheel_loads`) or scalars (the
    compiled loops)."""
    excess_f = np.sign(dfz_f) * np.maximum(np.abs(dfz_f) - fz_f, 0.0)
    excess_r = np.sign(dfz_r) * np.maximum(np.abs(dfz_r) - fz_r, 0.0)
    dfz_f = dfz_f - excess_f + excess_r * tr / tf
    dfz_r = dfz_r - excess_r + excess_f * tf / tr
    dfz_f = np.minimum(np.maximum(dfz_f, -fz_f), fz_f)
    dfz_r = np.minimum(np.maximum(dfz_r, -fz_r), fz_r)
    return fz_f - dfz_f, fz_f + dfz_f, fz_r - dfz_r, fz_r + dfz_r


def tabulated(table: np.ndarray, h: float, fz_a: float, fz_b: float) -> float:
    """Axle capacity (N) at wheel loads ``fz_a``, ``fz_b`` (N) by bilinear
    interpolation in ``table`` (N, N) of load step ``h`` (N) from 0 in both loads;
    loads beyond the table are clipped to it."""
    last = table.shape[0] - 2
    ta = max(fz_a, 0.0) / h
    tb = max(fz_b, 0.0) / h
    ia = min(int(ta), last)
    ib = min(int(tb), last)
    wa = min(ta - ia, 1.0)
    wb = min(tb - ib, 1.0)
    c00 = table[ia, ib]
    c10 = table[ia + 1, ib]
    c01 = table[ia, ib + 1]
    c11 = table[ia + 1, ib + 1]
    return c00 + wa * (c10 - c00) + wb * (c01 - c00 + wa * (c11 - c10 - c01 + c00))


def _steady_loads(row: np.ndarray, ay: float) -> tuple[float, float, float, float, float]:
    """(roll rad, wheel loads FL, FR, RL, RR N) of the steady state at lateral
    acceleration ``ay`` (m/s^2) of one row of coefficients
    (:attr:`~suspenv.models.minibus.handling_model.HandlingParams.rows`)."""
    phi = row[0] * ay
    fl, fr, rl, rr = axle_transfer(
        (row[1] * phi + row[3] * ay) / row[5],
        (row[2] * phi + row[4] * ay) / row[6],
        row[7], row[8], row[5], row[6],
    )  # fmt: skip
    return phi, fl, fr, rl, rr


def _circle_flags(
    row: np.ndarray, table: np.ndarray, h: float, ay: float
) -> tuple[bool, bool, bool]:
    """(front axle carries ``m a_y b/L``, not rolled over, rear axle carries ``m a_y
    a/L``) at lateral acceleration ``ay`` (m/s^2) of one row (:func:`_steady_loads`),
    the axle capacities by :func:`tabulated`."""
    _, fl, fr, rl, rr = _steady_loads(row, ay)
    front_ok = tabulated(table, h, fl, fr) >= row[9] * ay * row[11] / row[12]
    rear_ok = tabulated(table, h, rl, rr) >= row[9] * ay * row[10] / row[12]
    return front_ok, (fl > 0) or (rl > 0), rear_ok


def _circle_loop(
    rows: np.ndarray, table: np.ndarray, h: float, bits: int, scale: float, out: np.ndarray
) -> None:
    """Per row of coefficients ``rows`` (n, 17): the largest ``j`` in ``0 .. 2^bits -
    1`` whose steady state at ``a_y = j scale`` passes every condition of
    :func:`_circle_flags` (bisection: they are monotonic in a_y), and the front and
    rollover flags one step above it (which name the limit): ``out`` (n, 3)."""
    for i in range(rows.shape[0]):
        lo, hi = 0, 2**bits  # j = lo passes (a_y = 0); hi is the first failing or the end
        while hi - lo > 1:
            mid = (lo + hi) // 2
            f_ok, up, r_ok = _circle_flags(rows[i], table, h, mid * scale)
            if f_ok and up and r_ok:
                lo = mid
            else:
                hi = mid
        f_ok, up, r_ok = _circle_flags(rows[i], table, h, (lo + 1) * scale)
        out[i, 0], out[i, 1], out[i, 2] = lo, 1.0 if f_ok else 0.0, 1.0 if up else 0.0


def _sweep_loop(
    rows: np.ndarray,
    ay: np.ndarray,
    k: np.ndarray,
    grid: np.ndarray,
    radius: float,
    passes: int,
    out: np.ndarray,
) -> None:
    """Steady states on the circle of radius ``radius`` (m) at the lateral
    accelerations ``ay`` (N,) m/s^2 of every row of coefficients ``rows`` (n, 17):
    ``out`` (7, N, n) = (steer rad, roll rad, slip angles front, rear rad, axle forces
    front, rear N, 1.0 where both axles carry them and it has not rolled over); the
    slips by :func:`_slip_solve` on the tyres ``k`` (:func:`tyre_factors`)."""
    d, b, e = np.empty((2, 2)), np.empty((2, 2)), np.empty((2, 2))
    for a in range(ay.shape[0]):
        for i in range(rows.shape[0]):
            row, acc = rows[i], ay[a]
            phi, fl, fr, rl, rr = _steady_loads(row, acc)
            fyf = row[9] * acc * row[11] / row[12]
            fyr = row[9] * acc * row[10] / row[12]
            d[0, 0], b[0, 0], e[0, 0] = tyre_factors(fl, k)
            d[1, 0], b[1, 0], e[1, 0] = tyre_factors(fr, k)
            d[0, 1], b[0, 1], e[0, 1] = tyre_factors(rl, k)
            d[1, 1], b[1, 1], e[1, 1] = tyre_factors(rr, k)
            af, ok_f = _slip_solve(d, b, e, 0, k[1], grid, fyf, passes)
            ar, ok_r = _slip_solve(d, b, e, 1, k[1], grid, fyr, passes)
            steer = row[12] / radius + af - ar - row[13] * phi - row[14] * fyf
            out[0, a, i] = steer + row[15] * phi + row[16] * fyr
            out[1, a, i], out[2, a, i], out[3, a, i] = phi, af, ar
            out[4, a, i], out[5, a, i] = fyf, fyr
            out[6, a, i] = 1.0 if ok_f and ok_r and (fl > 0 or rl > 0) else 0.0


def _step(lam: np.ndarray, wn: np.ndarray, t: float, order: int) -> float:
    """d^order y/dt^order at time t (s) of the normalised yaw step response ``y(t) =
    sum_k wn_k (e^(lam_k t) - 1)`` (real part)."""
    total = 0j
    for k in range(lam.shape[0]):
        term = cmath.exp(lam[k] * t)
        for _ in range(order):
            term = term * lam[k]
        if order == 0:
            term = term - 1.0
        total += term * wn[k]
    return total.real


def _rel_gain(lam: np.ndarray, wn: np.ndarray, f: float) -> float:
    """|H(f)| / |H(0)| of the yaw rate at frequency f (Hz): ``|sum_k wn_k lam_k /
    (i 2 pi f - lam_k)|``."""
    s = complex(0.0, 2.0 * math.pi * f)
    total = 0j
    for k in range(lam.shape[0]):
        total += lam[k] / (s - lam[k]) * wn[k]
    return abs(total)


def _step_times(lam: np.ndarray, wn: np.ndarray, grid: np.ndarray, out: np.ndarray) -> None:
    """``out[:4]`` = (90 % time, peak time, 1 where the peak lies inside the grid, the
    peak value) of one row: the 90 % crossing (linear between the points of the evenly
    spaced ``grid``) and the grid's maximum, each refined by 4 Newton steps on the
    closed form (the grid's ``e^(lam t)`` by repeated products: start values only)."""
    n, m = grid.shape[0], lam.shape[0]
    z = np.empty(m, dtype=np.complex128)
    e = np.ones(m, dtype=np.complex128)
    for k in range(m):
        z[k] = cmath.exp(lam[k] * (grid[1] - grid[0]))
    k90, jmax = -1, 0
    y_prev, y_max = 0.0, -np.inf
    y_k, y_km1 = 0.0, 0.0
    for j in range(n):
        total = 0j
        for k in range(m):
            total += (e[k] - 1.0) * wn[k]
            e[k] = e[k] * z[k]
        y = total.real
        if k90 == -1 and y >= 0.9:
            k90, y_k, y_km1 = j, y, y_prev
        if y > y_max:
            y_max, jmax = y, j
        y_prev = y
    if k90 <= 0:  # no crossing (or at t = 0): the first interval, as numpy's argmax
        k90, y_km1, y_k = 1, _step(lam, wn, grid[0], 0), _step(lam, wn, grid[1], 0)
    t90 = (k90 - 1 + (0.9 - y_km1) / (y_k - y_km1)) * (grid[1] - grid[0])
    tp = grid[min(max(jmax, 1), n - 2)]
    for _ in range(4):
        t90 = t90 - (_step(lam, wn, t90, 0) - 0.9) / _step(lam, wn, t90, 1)
        tp = tp - _step(lam, wn, tp, 1) / _step(lam, wn, tp, 2)
    out[0], out[1] = t90, tp
    out[2] = 1.0 if 0 < jmax < n - 1 else 0.0
    out[3] = _step(lam, wn, tp, 0)


def _bandwidth(lam: np.ndarray, wn: np.ndarray, f: np.ndarray, f_max: float) -> float:
    """Lowest frequency (Hz) where the relative yaw-rate gain falls below 1/sqrt(2): the
    first grid interval ``f`` (log-spaced) that brackets it, then 10 Illinois passes in
    log f; ``f_max`` where it does not fall."""
    half = math.sqrt(0.5)
    k = -1
    g_prev = 0.0
    for j in range(f.shape[0]):
        g = _rel_gain(lam, wn, f[j]) - half
        if g < 0:
            k = j
            break
        g_prev = g
    if k == -1:
        return f_max
    if k == 0:  # below at the first point: the first interval, as numpy's argmax
        k, g_prev, g = 1, _rel_gain(lam, wn, f[0]) - half, _rel_gain(lam, wn, f[1]) - half
    lo, hi, g_lo, g_hi = math.log(f[k - 1]), math.log(f[k]), g_prev, g
    side = 0
    for _ in range(10):
        span = g_lo - g_hi
        mid = (lo * -g_hi + hi * g_lo) / span if span > 0 else hi
        g_mid = _rel_gain(lam, wn, math.exp(mid)) - half
        if g_mid < 0:
            if side == -1:
                g_lo = 0.5 * g_lo
            hi, g_hi, side = mid, g_mid, -1
        else:
            if side == 1:
                g_hi = 0.5 * g_hi
            lo, g_lo, side = mid, g_mid, 1
    return math.exp(lo if abs(g_lo) < abs(g_hi) else hi)


def _yaw_loop(
    lam: np.ndarray,
    V: np.ndarray,
    B: np.ndarray,
    grid: np.ndarray,
    f: np.ndarray,
    f_max: float,
    out: np.ndarray,
) -> None:
    """Per row of the poles ``lam`` (n, m), eigenvectors ``V`` (n, m, m) and steer
    inputs ``B`` (n, m) of the linear handling systems (state (v, r, phi, p)): the
    yaw-rate weights ``w_k = (V^-1 B)_k V[1, k] / lam_k`` (:func:`_solve`), the
    steady gain ``r_ss = -sum_k w_k`` and the normalised weights ``wn = w / r_ss``;
    ``out[i]`` = (:func:`_step_times`' four values, :func:`_bandwidth`, ``r_ss``)
    (n, 6)."""
    m = lam.shape[1]
    a = np.empty((m, m), dtype=np.complex128)
    x = np.empty((m, 1), dtype=np.complex128)
    wn = np.empty(m, dtype=np.complex128)
    for i in range(lam.shape[0]):
        for p in range(m):
            for q in range(m):
                a[p, q] = V[i, p, q]
            x[p, 0] = B[i, p]
        _solve(a, x)
        total = 0j
        for k in range(m):
            wn[k] = V[i, 1, k] * x[k, 0] / lam[i, k]
            total += wn[k]
        r_ss = -total.real
        for k in range(m):
            wn[k] = wn[k] / r_ss
        _step_times(lam[i], wn, grid, out[i])
        out[i, 4] = _bandwidth(lam[i], wn, f, f_max)
        out[i, 5] = r_ss


def _linear_loop(
    rows: np.ndarray,
    u: np.ndarray,
    cf: np.ndarray,
    cr: np.ndarray,
    A: np.ndarray,
    B: np.ndarray,
) -> None:
    """State matrices ``A`` (k, n, 4, 4) and steer inputs ``B`` (k, n, 4) of the
    linearised handling model (:func:`suspenv.models.minibus.handling_model.
    linear_system`: state (v, r, phi, p), input the front road-wheel steer) per row of
    coefficients ``rows`` (n, 22; :attr:`~suspenv.models.minibus.handling_model.
    HandlingParams.rows`) at speeds ``u`` (k, n) m/s and axle tyre stiffnesses ``cf``,
    ``cr`` (k, n) N/rad; ``A``, ``B`` zero on entry. The compliance steers solved into
    effective axle stiffnesses ``C' = C / (1 - C c_F)``; the axle forces ``Fyf = cf
    (delta + eps_f phi - (v + a r)/u)``, ``Fyr = cr (eps_r phi - (v - b r)/u)`` enter
    the lateral (``r1 = sum Fy - m u r``) and roll (``r2``) balances."""
    for q in range(u.shape[0]):
        for i in range(rows.shape[0]):
            row, uu = rows[i], u[q, i]
            m, a, b, iz, ixs, msh = row[9], row[10], row[11], row[17], row[18], row[19]
            cff = cf[q, i] / (1.0 - cf[q, i] * row[14])
            crr = cr[q, i] / (1.0 - cr[q, i] * row[16])
            det = m * ixs - msh**2
            f0, f1, f2 = -cff / uu, -cff * a / uu, cff * row[13]
            g0, g1, g2 = -crr / uu, crr * b / uu, crr * row[15]
            r10, r11, r12 = f0 + g0, f1 + g1 + -m * uu, f2 + g2
            r20, r21, r22 = msh * uu, row[20], -row[21]
            out = A[q, i]
            out[0, 0], out[3, 0] = ixs * r10 / det, msh * r10 / det
            out[0, 1], out[3, 1] = (ixs * r11 + msh * r20) / det, (msh * r11 + m * r20) / det
            out[0, 2], out[3, 2] = (ixs * r12 + msh * r21) / det, (msh * r12 + m * r21) / det
            out[0, 3], out[3, 3] = msh * r22 / det, m * r22 / det
            out[1, 0], out[1, 1] = (a * f0 - b * g0) / iz, (a * f1 - b * g1) / iz
            out[1, 2], out[2, 3] = (a * f2 - b * g2) / iz, 1.0
            B[q, i, 0], B[q, i, 1], B[q, i, 3] = ixs * cff / det, a * cff / iz, msh * cff / det


def _response_loop(A: np.ndarray, B: np.ndarray, s: np.ndarray, X: np.ndarray) -> None:
    """Frequency response ``X[i, k] = (s_k I - A[i])^-1 B[i]`` (n, Nf, m, complex) of
    the linear systems ``A`` (n, m, m), ``B`` (n, m) at the complex frequencies ``s``
    (Nf,) (:func:`suspenv.models.minibus.handling_model.steer_response`), by Gaussian
    elimination with partial pivoting."""
    m = A.shape[1]
    a = np.empty((m, m), dtype=np.complex128)
    x = np.empty((m, 1), dtype=np.complex128)
    for i in range(A.shape[0]):
        for k in range(s.shape[0]):
            for p in range(m):
                for q in range(m):
                    a[p, q] = -A[i, p, q]
                a[p, p] += s[k]
                x[p, 0] = B[i, p]
            _solve(a, x)
            for p in range(m):
                X[i, k, p] = x[p, 0]


_AXLE = ("_wheel_force", "_axle_force", "_capacity", "_slip_bracket", "_slip_solve")
#: :func:`_capacity_loop`, compiled at its first call (numba's cache keeps it)
capacity_loop = compiled.Lazy(globals(), _AXLE, _capacity_loop)
#: :func:`_yaw_loop`, compiled at its first call (numba's cache keeps it)
yaw_loop = compiled.Lazy(
    globals(), ("_solve", "_step", "_rel_gain", "_step_times", "_bandwidth"), _yaw_loop
)
#: :func:`_circle_loop`, compiled at its first call (numba's cache keeps it)
_LOADS = ("axle_transfer", "_steady_loads")
circle_loop = compiled.Lazy(globals(), (*_LOADS, "tabulated", "_circle_flags"), _circle_loop)
#: :func:`_sweep_loop`, compiled at its first call (numba's cache keeps it)
sweep_loop = compiled.Lazy(
    globals(), (*_LOADS, *_AXLE, "tyre_cornering", "tyre_factors"), _sweep_loop
)
#: :func:`_linear_loop`, compiled at its first call (numba's cache keeps it)
linear_loop = compiled.Lazy(globals(), (), _linear_loop)
#: :func:`_response_loop`, compiled at its first call (numba's cache keeps it)
response_loop = compiled.Lazy(globals(), ("_solve",), _response_loop)
