"""The Python loop of the quarter-car rig integrator (tests only): the reference of the
compiled loop :mod:`suspenv.models.components.rig_kernel`.

The same scheme as the product (exact first-order-hold step of the linear part, the
element force solved implicitly by a chord step and secant steps, element states advanced
by their exact solution along the step), written a second way: closures over plain
floats, one per element, with the laws bound from the effect's parameters (the formulas
of :data:`suspenv.models.effects.laws.STATELESS`) instead of codes and parameter
rows. It shares only the step matrices
(:func:`~suspenv.models.components.rig_integrator.step_matrices`). Frames, units and
signs: those of :mod:`suspenv.models.components.rig_integrator`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from suspenv.core.errors import EvaluationError
from suspenv.models.components.rig_integrator import EXACT_STATEFUL, step_matrices
from suspenv.models.effects import Effect
from suspenv.models.effects.laws import STATELESS

#: stateless kind -> float force law ``F(x, v, p)`` [N] of the effect's parameters ``p``
#: (floats): the formulas of :data:`suspenv.models.effects.laws.STATELESS`
_LAWS: dict[str, Callable[[float, float, dict[str, float]], float]] = {
    "coulomb_friction": lambda x, v, p: p["f_c"] * math.tanh(v / p["v_eps"]),
    "stribeck_friction": lambda x, v, p: (
        (p["f_c"] + (p["f_s"] - p["f_c"]) * math.exp(-((v / p["v_s"]) ** 2)))
        * math.tanh(v / p["v_eps"])
    ),
    "directional_friction": lambda x, v, p: (
        0.5 * (p["f_pos"] + p["f_neg"]) * math.tanh(v / p["v_eps"])
        + 0.5 * (p["f_pos"] - p["f_neg"]) * abs(math.tanh(v / p["v_eps"]))
    ),
    "bump_stop": lambda x, v, p: p["k_stop"] * (x - p["gap"]) ** p["p"] if x > p["gap"] else 0.0,
    "rebound_stop": lambda x, v, p: (
        -p["k_stop"] * (-x - p["gap"]) ** p["p"] if -x > p["gap"] else 0.0
    ),
    "bump_and_rebound_stops": lambda x, v, p: (
        p["k_bump"] * (x - p["gap_bump"]) ** p["p"]
        if x > p["gap_bump"]
        else (-p["k_rebound"] * (-x - p["gap_rebound"]) ** p["p"] if -x > p["gap_rebound"] else 0.0)
    ),
    "cubic_stiffness": lambda x, v, p: p["k3"] * (x - p["x_0"]) * (x - p["x_0"]) * (x - p["x_0"]),
    "progressive_stiffness": lambda x, v, p: (
        (p["k_p"] if x > 0.0 else -p["k_p"]) * (abs(x) - p["x0"]) ** 2 if abs(x) > p["x0"] else 0.0
    ),
    "damper_asymmetry": lambda x, v, p: p["dc_rebound"] * v if v < 0.0 else 0.0,
    "digressive_damping": lambda x, v, p: p["c_low"] * v / (1.0 + abs(v) / p["v_knee"]),
    "asymmetric_digressive_damping": lambda x, v, p: (
        p["c_bump"] * v / (1.0 + v / p["v_knee_bump"])
        if v >= 0.0
        else p["c_rebound"] * v / (1.0 - v / p["v_knee_rebound"])
    ),
    "gas_spring": lambda x, v, p: p["f_0"] + p["k_gas"] * x,
    "force_offset": lambda x, v, p: p["offset"],
    "kelvin_voigt": lambda x, v, p: p["k"] * x + p["c"] * v,
    "low_speed_deficit": lambda x, v, p: -p["f_d"] * math.tanh(v / p["v_band"]),
}


def _element_law(e: Effect) -> Callable[[float, float], float]:
    """Float force law ``F(x, v)`` [N] of a stateless element (:data:`_LAWS`)."""
    law, p = _LAWS[e.kind], {k: float(v) for k, v in e.params.items()}
    return lambda x, v: law(x, v, p)


def _sum_of(laws: list[Callable[[float, float], float]]) -> Callable[[float, float], float]:
    """``F(x, v)`` of several stateless elements together."""
    if not laws:
        return lambda x, v: 0.0
    if len(laws) == 1:
        return laws[0]
    if len(laws) == 2:
        a, b = laws
        return lambda x, v: a(x, v) + b(x, v)
    return lambda x, v: sum(law(x, v) for law in laws)


class _Dahl:
    """Dahl state (hysteretic force [N]) advanced exactly along a deflection increment."""

    def __init__(self, e: Effect):
        self.f_c = float(e.params["f_c"])
        self.rate = float(e.params["sigma"]) / self.f_c if self.f_c > 0.0 else 0.0

        rate, f_c, exp = self.rate, self.f_c, math.exp

        def step(z0: float, x0: float, x1: float, v0: float, v1: float, h: float) -> float:
            if rate == 0.0:
                return 0.0
            dx = x1 - x0
            if dx > 0.0:
                return f_c + (z0 - f_c) * exp(-rate * dx)
            if dx < 0.0:
                return -f_c + (z0 + f_c) * exp(rate * dx)
            return z0

        self.step, self.force = step, None


class _LuGre:
    """LuGre bristle deflection ``z`` [m], stepped along the deflection increment with
    the Stribeck level ``g`` taken at the end velocity (implicit): in displacement the
    bristle law ``dz/dx = 1 - sigma0 sign(v) z / g`` is linear, so ``z`` approaches
    ``sign(dx) g / sigma0`` exponentially over ``g / sigma0``, exactly for constant ``g``.
    The force is ``sigma0 z + sigma1 dz/dt`` at the end of the step."""

    def __init__(self, e: Effect):
        p = {k: float(v) for k, v in e.params.items()}
        s0, s1, f_c, df, ws = p["sigma0"], p["sigma1"], p["f_c"], p["f_s"] - p["f_c"], 1 / p["v_s"]
        exp = math.exp
        floor = 1e-12  # zero friction level: the element carries no force

        def level(v: float) -> float:
            g = f_c + df * exp(-((v * ws) ** 2))
            return g if g > floor else floor

        def step(z0: float, x0: float, x1: float, v0: float, v1: float, h: float) -> float:
            g = level(v1)
            zss = g / s0
            dx = x1 - x0
            if dx > 0.0:
                return zss + (z0 - zss) * exp(-s0 * dx / g)
            if dx < 0.0:
                return -zss + (z0 + zss) * exp(s0 * dx / g)
            return z0

        def force(z: float, v: float) -> float:
            return s0 * z + s1 * (v - s0 * abs(v) * z / level(v))

        self.step, self.force = step, force


class _Maxwell:
    """Maxwell element force [N]: first-order lag ``F' = k_m (v - F / c_m)``, exact for a
    velocity linear over the step."""

    def __init__(self, e: Effect):
        self.k_m = float(e.params["k_m"])
        self.tau = float(e.params["c_m"]) / self.k_m
        self._h = -1.0
        self.force = None

    def step(self, z0: float, x0: float, x1: float, v0: float, v1: float, h: float) -> float:
        if h != self._h:
            tau = self.tau
            decay = math.exp(-h / tau)
            self._h, self._decay = h, decay
            self._a = self.k_m * tau * (1.0 - decay)
            self._b = self.k_m * (tau - tau * tau * (1.0 - decay) / h)
        return self._decay * z0 + self._a * v0 + self._b * (v1 - v0)


#: kind -> state stepper; ``force`` is None where the state is the element force itself
_STATE_TYPES: dict[str, type] = {
    "dahl_hysteresis": _Dahl,
    "maxwell_viscoelastic": _Maxwell,
    "lugre_friction": _LuGre,
}


def integrate_reference(
    m_s: float,
    m_u: float,
    base: dict[str, float],
    effects: Sequence[Effect],
    t: np.ndarray,
    road: np.ndarray,
    nsub: int = 1,
    tol: float = 1e-7,
    max_iter: int = 8,
    actuator: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`suspenv.models.components.rig_integrator.integrate` by the Python loop:
    body acceleration [m/s^2] and suspension deflection [m] at the samples ``t``."""
    k_s, c_s, k_t = float(base["k_s"]), float(base["c_s"]), float(base["k_t"])
    element_force = _sum_of([_element_law(e) for e in effects if e.kind in STATELESS])
    act_l = None if actuator is None else np.asarray(actuator, float).tolist()
    fa_end = 0.0 if act_l is None else act_l[0]

    def with_actuator(x: float, v: float) -> float:
        return element_force(x, v) + fa_end

    stateless = element_force if act_l is None else with_actuator
    states: list[Any] = [_STATE_TYPES[e.kind](e) for e in effects if e.kind in EXACT_STATEFUL]
    dts = np.diff(t)
    mats: dict[float, tuple[list[list[float]], ...]] = {}

    def matrices(h: float) -> tuple[list[list[float]], ...]:
        key = round(h, 15)
        if key not in mats:
            phi, g0, g1 = step_matrices(m_s, m_u, k_s, c_s, k_t, h)
            mats[key] = (phi.tolist(), g0.tolist(), g1.tolist())
        return mats[key]

    r0 = float(road[0])
    zs, vs, zu, vu = r0, 0.0, r0, 0.0
    z = [0.0] * len(states)
    x0, v0 = 0.0, 0.0
    fe = stateless(0.0, 0.0)
    acc = np.empty(t.size)
    defl = np.empty(t.size)
    acc[0] = fe / m_s
    defl[0] = 0.0
    road_l, dts_l = road.tolist(), dts.tolist()
    has_effects = bool(effects) or act_l is not None
    uniform = bool(np.all(np.abs(dts - dts[0]) <= 1e-9 * abs(dts[0])))
    h = dts_l[0] / nsub
    (p0, p1, p2, p3), (a0, a1, a2, a3), (b0, b1, b2, b3) = matrices(h)
    gx, gv = b2[1] - b0[1], b3[1] - b1[1]
    slope = 1.0  # dG/dF of the force equation at the last step (chord start)
    f_prev = fe
    for k in range(t.size - 1):
        if not uniform:
            h = dts_l[k] / nsub
            (p0, p1, p2, p3), (a0, a1, a2, a3), (b0, b1, b2, b3) = matrices(h)
            gx, gv = b2[1] - b0[1], b3[1] - b1[1]
        ra, dr = road_l[k], (road_l[k + 1] - road_l[k]) / nsub
        for j in range(nsub):
            r_start, r_end = ra + dr * j, ra + dr * (j + 1)
            if act_l is not None:
                fa_end = act_l[k] + (act_l[k + 1] - act_l[k]) * (j + 1) / nsub
            # end state without the unknown end force F1: known part + g * F1
            kz_s = p0[0] * zs + p0[1] * vs + p0[2] * zu + p0[3] * vu
            kz_s += a0[0] * r_start + a0[1] * fe + b0[0] * r_end
            kv_s = p1[0] * zs + p1[1] * vs + p1[2] * zu + p1[3] * vu
            kv_s += a1[0] * r_start + a1[1] * fe + b1[0] * r_end
            kz_u = p2[0] * zs + p2[1] * vs + p2[2] * zu + p2[3] * vu
            kz_u += a2[0] * r_start + a2[1] * fe + b2[0] * r_end
            kv_u = p3[0] * zs + p3[1] * vs + p3[2] * zu + p3[3] * vu
            kv_u += a3[0] * r_start + a3[1] * fe + b3[0] * r_end
            f1 = 0.0
            if has_effects:
                xk, vk = kz_u - kz_s, kv_u - kv_s
                if states:
                    f1, z, slope = _solve_with_states(
                        stateless, states, z, x0, v0, xk, vk, gx, gv, h, fe, slope, tol, max_iter
                    )
                else:
                    f1, slope = _solve_stateless(
                        stateless, xk, vk, gx, gv, fe, f_prev, slope, tol, max_iter
                    )
            zs, vs = kz_s + b0[1] * f1, kv_s + b1[1] * f1
            zu, vu = kz_u + b2[1] * f1, kv_u + b3[1] * f1
            x0, v0, f_prev, fe = zu - zs, vu - vs, fe, f1
        if not (math.isfinite(zs) and math.isfinite(zu) and math.isfinite(vs + vu)):
            raise EvaluationError(
                f"quarter_car_rig: simulation diverged at t={t[k + 1]:.4g} s (sub-steps {nsub})"
            )
        acc[k + 1] = (k_s * x0 + c_s * v0 + fe) / m_s
        defl[k + 1] = x0
    return acc, defl


def _solve_with_states(
    stateless: Callable[[float, float], float],
    states: list[Any],
    z0: list[float],
    x0: float,
    v0: float,
    xk: float,
    vk: float,
    gx: float,
    gv: float,
    h: float,
    f_guess: float,
    slope: float,
    tol: float,
    max_iter: int,
) -> tuple[float, list[float], float]:
    """Root ``F`` of ``F = f(xk + gx F, vk + gv F, z(F))``, the element states there and
    the last secant slope (chord start, then secant steps)."""

    if len(states) == 1 and states[0].force is None:
        step, z00 = states[0].step, z0[0]

        def residual(f: float) -> tuple[float, list[float]]:
            x, v = xk + gx * f, vk + gv * f
            z1 = step(z00, x0, x, v0, v, h)
            return f - stateless(x, v) - z1, [z1]

    else:

        def residual(f: float) -> tuple[float, list[float]]:
            x, v = xk + gx * f, vk + gv * f
            zs = [st.step(zi, x0, x, v0, v, h) for st, zi in zip(states, z0, strict=True)]
            total = stateless(x, v)
            for st, zi in zip(states, zs, strict=True):
                total += zi if st.force is None else st.force(zi, v)
            return f - total, zs

    fa = f_guess
    ga, za = residual(fa)
    if abs(ga) <= tol * (1.0 + abs(fa)):
        return fa, za, slope
    return _chord_secant(residual, fa, ga, slope, tol, max_iter)


def _solve_stateless(
    stateless: Callable[[float, float], float],
    xk: float,
    vk: float,
    gx: float,
    gv: float,
    fe: float,
    f_prev: float,
    slope: float,
    tol: float,
    max_iter: int,
) -> tuple[float, float]:
    """Root ``F`` of ``G(F) = F - f(xk + gx F, vk + gv F)`` for stateless elements and the
    last secant slope, from the linear extrapolation ``2 fe - f_prev`` of the force."""

    def residual(f: float) -> tuple[float, None]:
        return f - stateless(xk + gx * f, vk + gv * f), None

    fa = 2.0 * fe - f_prev
    ga = residual(fa)[0]
    f1, _, slope = _chord_secant(residual, fa, ga, slope, tol, max_iter)
    return f1, slope


def _chord_secant(
    residual: Callable[[float], tuple[float, Any]],
    fa: float,
    ga: float,
    slope: float,
    tol: float,
    max_iter: int,
) -> tuple[float, Any, float]:
    """From ``fa`` with residual ``ga``: a chord step with the last ``slope``, then secant
    steps to ``|G| <= tol (1 + |F|)``. Returns the force, what ``residual`` gave with it
    (the element states) and the new slope (``G' >= 1`` for passive elements: a slope
    not above 0.05 is taken as 1)."""
    fb = fa - ga / slope
    gb, zb = residual(fb)
    for _ in range(max_iter):
        if abs(gb) <= tol * (1.0 + abs(fb)) or gb == ga:
            break
        fa, ga, fb = fb, gb, fb - gb * (fb - fa) / (gb - ga)
        gb, zb = residual(fb)
    if fb != fa and gb != ga:
        slope = (gb - ga) / (fb - fa)
        if not slope > 0.05:
            slope = 1.0
    return fb, zb, slope
