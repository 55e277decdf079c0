"""Compiled loop of the quarter-car rig integrator (numba).

:func:`suspenv.models.components.rig_integrator.integrate` computes the step matrices
and calls :data:`run`: the loop that advances the exact linear step and solves the
implicit element force sample by sample (the chord-then-secant root search), with the
element laws and the exact state steps of Dahl, Maxwell and LuGre. Frames, units and
signs are those of :mod:`suspenv.models.components.rig_integrator`. Its reference is the
same scheme written as closures over plain floats, ``tests/rig_reference.py``
(``tests/test_rig_kernel.py`` compares the two for every element kind).

Elements are passed as codes with their parameters in rows of a float array
(:func:`pack`). Without numba (an unusual platform, :data:`suspenv.core.compiled.AVAILABLE`
False), :func:`_run` runs as plain Python.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from suspenv.core import compiled
from suspenv.models.effects import Effect
from suspenv.models.effects.laws import FLOATS, JITABLE, STATELESS

#: stateless element kind -> code: its place in :data:`.laws.STATELESS` (:func:`_law`)
LAW_CODES: dict[str, int] = {kind: code for code, kind in enumerate(STATELESS)}
#: stateful element kind -> code (their exact state steps: :func:`_state_step`)
STATE_CODES: dict[str, int] = {"dahl_hysteresis": 0, "maxwell_viscoelastic": 1, "lugre_friction": 2}
N_PAR = 5  # parameter slots per element


def _state_params(e: Effect) -> list[float]:
    """The parameters of a stateful element as :func:`_state_step` reads them."""
    p = {k: float(v) for k, v in e.params.items()}
    if e.kind == "dahl_hysteresis":
        return [p["f_c"], p["sigma"] / p["f_c"] if p["f_c"] > 0.0 else 0.0]
    if e.kind == "maxwell_viscoelastic":
        return [p["k_m"], p["c_m"] / p["k_m"]]
    if e.kind == "lugre_friction":
        return [p["sigma0"], p["sigma1"], p["f_c"], p["f_s"], p["v_s"]]
    raise KeyError(e.kind)


def pack(effects: Sequence[Effect]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(law codes (L,), law parameters (L, 5), state codes (S,), state parameters (S, 5))
    of ``effects`` in their order (stateless and stateful kept apart: the stateless laws
    are summed first)."""
    laws = [e for e in effects if e.kind in LAW_CODES]
    states = [e for e in effects if e.kind in STATE_CODES]
    law_par = [[float(e.params[name]) for name in STATELESS[e.kind][2]] for e in laws]
    return (
        np.array([LAW_CODES[e.kind] for e in laws], np.int64),
        _rows(law_par),
        np.array([STATE_CODES[e.kind] for e in states], np.int64),
        _rows([_state_params(e) for e in states]),
    )


def _rows(values: list[list[float]]) -> np.ndarray:
    """The parameter lists as rows of :data:`N_PAR` slots (unused slots zero)."""
    out = np.zeros((len(values), N_PAR))
    for i, vals in enumerate(values):
        out[i, : len(vals)] = vals
    return out


def _law(code: int, p: np.ndarray, x: float, v: float) -> float:
    """Force [N] of one stateless element (:data:`LAW_CODES`)."""
    if code < 7:
        return _friction_or_stop(code, p, x, v)
    return _spring_or_damper(code, p, x, v)


def _friction_or_stop(code: int, p: np.ndarray, x: float, v: float) -> float:
    """Force [N] of a friction element or an end stop (codes 0 to 6)."""
    if code == 0:
        return FLOATS.coulomb_smooth(v, p[0], p[1])
    if code == 1:
        return FLOATS.stribeck_friction(v, p[0], p[1], p[2], p[3])
    if code == 2:
        return FLOATS.coulomb_directional(v, p[0], p[1], p[2])
    if code == 3:
        return FLOATS.low_speed_deficit(v, p[0], p[1])
    if code == 4:
        return FLOATS.bump_stop(x, p[0], p[1], p[2])
    if code == 5:
        return FLOATS.rebound_stop(x, p[0], p[1], p[2])
    return FLOATS.bump_and_rebound_stops(x, p[0], p[1], p[2], p[3], p[4])


def _spring_or_damper(code: int, p: np.ndarray, x: float, v: float) -> float:
    """Force [N] of a spring-like or damper element (codes 7 to 14)."""
    if code == 7:
        return FLOATS.cubic_stiffness(x, p[0], p[1])
    if code == 8:
        return FLOATS.progressive_spring(x, p[0], p[1])
    if code == 9:
        return FLOATS.gas_spring(x, p[0], p[1])
    if code == 10:
        return FLOATS.force_offset(x, p[0])
    if code == 11:
        return FLOATS.kelvin_voigt(x, v, p[0], p[1])
    if code == 12:
        return FLOATS.extra_rebound_damping(v, p[0])
    if code == 13:
        return FLOATS.damper_digressive(v, p[0], p[1])
    return FLOATS.damper_digressive_asymmetric(v, p[0], p[1], p[2], p[3])


def _stateless(codes: np.ndarray, par: np.ndarray, x: float, v: float, fa: float) -> float:
    """Sum of the stateless elements' forces [N] plus the actuator force ``fa``."""
    total = 0.0
    if codes.size:
        total = _law(codes[0], par[0], x, v)
        for i in range(1, codes.size):
            total += _law(codes[i], par[i], x, v)
    return total + fa


def _lugre_level(p: np.ndarray, v: float) -> float:
    """The LuGre element's friction level [N], floored at 1e-12 N (as in its law)."""
    return max(FLOATS.stribeck_level(v, p[2], p[3], p[4]), 1e-12)


def _state_step(
    code: int, p: np.ndarray, mx: np.ndarray, z0: float, x0: float, x1: float, v0: float, v1: float
) -> float:
    """The state of one stateful element at the end of the step (``mx``: the Maxwell
    coefficients of the step's length: decay, a, b)."""
    if code == 0:  # Dahl: saturation force f_c, rate sigma / f_c
        return _saturating(z0, p[0], p[1], 1.0, x1 - x0) if p[1] != 0.0 else 0.0
    if code == 1:  # Maxwell
        return mx[0] * z0 + mx[1] * v0 + mx[2] * (v1 - v0)
    g = _lugre_level(p, v1)  # LuGre: bristle deflection saturates at g / sigma0
    return _saturating(z0, g / p[0], p[0], g, x1 - x0)


def _saturating(z0: float, level: float, rate: float, scale: float, dx: float) -> float:
    """The exact state after a monotone increment ``dx`` of ``dz/dx = rate / scale
    (sign(dx) level - z)``: the Dahl and LuGre elements' relaxation towards their
    saturated state, with the velocity held over the step."""
    if dx > 0.0:
        return level + (z0 - level) * math.exp(-rate * dx / scale)
    if dx < 0.0:
        return -level + (z0 + level) * math.exp(rate * dx / scale)
    return z0


def _states_residual(
    f: float,
    law_codes: np.ndarray,
    law_par: np.ndarray,
    st_codes: np.ndarray,
    st_par: np.ndarray,
    mx: np.ndarray,
    z0: np.ndarray,
    z_out: np.ndarray,
    x0: float,
    v0: float,
    xk: float,
    vk: float,
    gx: float,
    gv: float,
    fa: float,
) -> float:
    """``F - f(x(F), v(F), z(F))`` with the element states written to ``z_out``."""
    x, v = xk + gx * f, vk + gv * f
    S = st_codes.size
    for i in range(S):
        z_out[i] = _state_step(st_codes[i], st_par[i], mx[i], z0[i], x0, x, v0, v)
    if S == 1 and st_codes[0] != 2:  # one state that is the element force itself
        return f - _stateless(law_codes, law_par, x, v, fa) - z_out[0]
    total = _stateless(law_codes, law_par, x, v, fa)
    for i in range(S):
        if st_codes[i] == 2:
            p = st_par[i]
            total += FLOATS.lugre_force(z_out[i], v, p[0], p[1], p[2], p[3], p[4])
        else:
            total += z_out[i]
    return f - total


def _maxwell_coefficients(st_codes: np.ndarray, st_par: np.ndarray, h: float, mx: np.ndarray):
    for i in range(st_codes.size):
        if st_codes[i] == 1:
            k_m, tau = st_par[i, 0], st_par[i, 1]
            decay = math.exp(-h / tau)
            mx[i, 0] = decay
            mx[i, 1] = k_m * tau * (1.0 - decay)
            mx[i, 2] = k_m * (tau - tau * tau * (1.0 - decay) / h)


def _known_part(
    p: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    i: int,
    zs: float,
    vs: float,
    zu: float,
    vu: float,
    r_start: float,
    fe: float,
    r_end: float,
) -> float:
    """Row ``i`` of the end state without the unknown end force (``Phi s0 + G0 u0`` and
    the road part of ``G1 u1``)."""
    y = p[i, 0] * zs + p[i, 1] * vs + p[i, 2] * zu + p[i, 3] * vu
    y += a[i, 0] * r_start + a[i, 1] * fe + b[i, 0] * r_end
    return y


def _secant_slope(fa: float, ga: float, fb: float, gb: float, slope: float) -> float:
    """The slope of the last secant (the next step's chord start); 1 where it is not
    above 0.05 (``G' >= 1`` for passive elements: a guard)."""
    if fb != fa and gb != ga:
        slope = (gb - ga) / (fb - fa)
        if not slope > 0.05:
            slope = 1.0
    return slope


def _run(
    phis: np.ndarray,
    g0s: np.ndarray,
    g1s: np.ndarray,
    mat_of_step: np.ndarray,
    h_of_step: np.ndarray,
    nsub: int,
    road: np.ndarray,
    act: np.ndarray,
    has_act: bool,
    law_codes: np.ndarray,
    law_par: np.ndarray,
    st_codes: np.ndarray,
    st_par: np.ndarray,
    k_s: float,
    c_s: float,
    m_s: float,
    tol: float,
    max_iter: int,
    acc: np.ndarray,
    defl: np.ndarray,
) -> int:
    """The loop of ``rig_integrator.integrate``; writes ``acc`` and ``defl`` (T,) and
    returns -1, or the sample interval ``k`` after which the state is not finite."""
    T = road.size
    S = st_codes.size
    has_effects = law_codes.size > 0 or S > 0 or has_act
    fa_end = act[0] if has_act else 0.0
    zs, vs, zu, vu = road[0], 0.0, road[0], 0.0
    z = np.zeros(S)
    z_a = np.zeros(S)
    z_b = np.zeros(S)
    mx = np.zeros((max(S, 1), 3))
    x0, v0 = 0.0, 0.0
    fe = _stateless(law_codes, law_par, 0.0, 0.0, fa_end)
    acc[0] = fe / m_s
    defl[0] = 0.0
    slope = 1.0
    f_prev = fe
    last_mat = -1
    last_h = -1.0
    p = phis[0]
    a = g0s[0]
    b = g1s[0]
    gx, gv = 0.0, 0.0
    for k in range(T - 1):
        mi = mat_of_step[k]
        if mi != last_mat:
            p, a, b = phis[mi], g0s[mi], g1s[mi]
            gx, gv = b[2, 1] - b[0, 1], b[3, 1] - b[1, 1]
            last_mat = mi
        h = h_of_step[k]
        if h != last_h:
            _maxwell_coefficients(st_codes, st_par, h, mx)
            last_h = h
        ra, dr = road[k], (road[k + 1] - road[k]) / nsub
        for j in range(nsub):
            r_start, r_end = ra + dr * j, ra + dr * (j + 1)
            if has_act:
                fa_end = act[k] + (act[k + 1] - act[k]) * (j + 1) / nsub
            kz_s = _known_part(p, a, b, 0, zs, vs, zu, vu, r_start, fe, r_end)
            kv_s = _known_part(p, a, b, 1, zs, vs, zu, vu, r_start, fe, r_end)
            kz_u = _known_part(p, a, b, 2, zs, vs, zu, vu, r_start, fe, r_end)
            kv_u = _known_part(p, a, b, 3, zs, vs, zu, vu, r_start, fe, r_end)
            f1 = 0.0
            if has_effects:
                xk, vk = kz_u - kz_s, kv_u - kv_s
                # start from the last force where states may solve the step already, else
                # from the linear extrapolation of the force
                fa = fe if S else 2.0 * fe - f_prev
                ga = _states_residual(
                    fa, law_codes, law_par, st_codes, st_par, mx, z, z_a,
                    x0, v0, xk, vk, gx, gv, fa_end,
                )  # fmt: skip
                if S and abs(ga) <= tol * (1.0 + abs(fa)):
                    f1 = fa
                    z[:] = z_a
                else:
                    fb = fa - ga / slope
                    gb = _states_residual(
                        fb, law_codes, law_par, st_codes, st_par, mx, z, z_b,
                        x0, v0, xk, vk, gx, gv, fa_end,
                    )  # fmt: skip
                    for _ in range(max_iter):
                        if abs(gb) <= tol * (1.0 + abs(fb)) or gb == ga:
                            break
                        fa, ga, fb = fb, gb, fb - gb * (fb - fa) / (gb - ga)
                        gb = _states_residual(
                            fb, law_codes, law_par, st_codes, st_par, mx, z, z_b,
                            x0, v0, xk, vk, gx, gv, fa_end,
                        )  # fmt: skip
                    slope = _secant_slope(fa, ga, fb, gb, slope)
                    f1 = fb
                    z[:] = z_b
            zs, vs = kz_s + b[0, 1] * f1, kv_s + b[1, 1] * f1
            zu, vu = kz_u + b[2, 1] * f1, kv_u + b[3, 1] * f1
            x0, v0, f_prev, fe = zu - zs, vu - vs, fe, f1
        if not (math.isfinite(zs) and math.isfinite(zu) and math.isfinite(vs + vu)):
            return k
        acc[k + 1] = (k_s * x0 + c_s * v0 + fe) / m_s
        defl[k + 1] = x0
    return -1


#: :func:`_run`, compiled at its first call (about 10 s once per machine, then 0.3 s per
#: process from numba's cache); without numba, :func:`_run` itself
run = compiled.Lazy(
    globals(),
    (
        "_law",
        "_friction_or_stop",
        "_spring_or_damper",
        "_stateless",
        "_lugre_level",
        "_state_step",
        "_saturating",
        "_states_residual",
        "_maxwell_coefficients",
        "_known_part",
        "_secant_slope",
    ),
    _run,
    jitable=JITABLE,
)
