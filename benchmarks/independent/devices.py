"""The four devices: equations of motion and what their sensors see (noise-free).

Signs and frames:

* damper / MR damper on a dyno or shaking table: the imposed stroke ``x`` [m] is positive
  in compression (from mid-stroke), ``v = dx/dt`` [m/s]; the load cell force ``F`` [N] is
  positive in compression (the damper pushing back against being shortened), so a
  damper absorbs power when ``mean(F v) > 0``. The gas / accumulator force is ``f0 > 0``.
* friction guide: position ``x`` [m] along the guide, the motor force ``u`` [N] acts on the
  carriage in ``+x``; a PD position loop with feedforward (gains from a crossover
  frequency) tracks a reference; the carriage obeys ``m a = u - R(x, v)`` with the
  resistance ``R = c v + effect``.
* quarter car on a shaker: heights ``z_s`` (body), ``z_u`` (wheel), road ``r`` [m],
  positive up, measured from static equilibrium (gravity balanced by the preloads, the
  tyre never leaves the plate); deflection ``d = z_u - z_s`` positive in compression;
  the suspension force ``F(d, d')`` [N] pushes body and wheel apart;
  ``m_s z_s'' = F + f_a``, ``m_u z_u'' = -F - f_a + k_t (r - z_u)`` with the actuator
  force ``f_a`` [N] (positive pushing body and wheel apart).

Each simulation returns the physical channels and, along the actual trajectory, the base
force (what the user's baseline model explains) and the effect force (the rest): for the
damper ``F - (f0 + k x + c v)``; for the guide ``u - (m a + c v)``; for the quarter car
``F - (k_s d + c_s d')``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from benchmarks.independent.effects import ForceLaw, contact, dead_band
from benchmarks.independent.integrate import integrate
from benchmarks.independent.signals import MinJerkPath, SineBlocks, SumOfSines, Tabulated

RTOL = 1e-7
RTOL_QC = 1e-6  # relative tolerance of the quarter car (closed-form error ~5e-6)


@dataclass
class Backlash:
    """Free play of ``gap`` [m] on each side, contact stiffness ``k`` [N/m] (and, for the
    guide, contact damping ``c`` [N s/m] and motor-side mass fraction ``motor_fraction``)."""

    gap: float
    k: float
    c: float = 0.0
    motor_fraction: float = 0.3


@dataclass
class Simulation:
    """Noise-free channels (SI, device signs), base and effect force [N] per sample."""

    t: np.ndarray
    channels: dict[str, np.ndarray]
    base_force: np.ndarray
    effect_force: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)


def _atol(kinds: list[str]) -> np.ndarray:
    scale = {"pos": 1e-10, "vel": 1e-9, "force": 1e-7, "bw": 1e-11}
    return np.array([scale[k] for k in kinds])


def _law_state_kind(law: ForceLaw) -> list[str]:
    if not law.n_states:
        return []
    return ["bw"] if law.label == "hysteresis" else ["force"]


def simulate_component(
    law: ForceLaw, exc: SineBlocks, t: np.ndarray, backlash: Backlash | None = None
) -> Simulation:
    """A damper driven along the stroke ``exc`` (compression positive) sampled at ``t``."""
    x, v, _ = exc.evaluate(t)
    if backlash is None:

        def rhs(tt: float, s: np.ndarray) -> np.ndarray:
            xx, vv = exc.at(tt)
            return law.state_rate(xx, vv, s)

        s = integrate(rhs, np.zeros(law.n_states), t, rtol=RTOL, atol=_atol(_law_state_kind(law)))
        state = s[:, 0] if law.n_states else 0.0
        force = law.total(x, v, state)
    else:
        # massless rod end x_d behind the play: c x_d' = F_link - f0 - k x_d
        b, kl = backlash.gap, backlash.k

        def rhs_b(tt: float, s: np.ndarray) -> np.ndarray:
            xx, _ = exc.at(tt)
            fl = kl * float(dead_band(xx - s[0], b))
            return np.array([(fl - law.f0 - law.k * s[0]) / law.c])

        x0 = float(x[0]) - np.sign(law.f0) * (b + abs(law.f0) / kl)
        s = integrate(rhs_b, np.array([x0]), t, rtol=RTOL, atol=_atol(["pos"]))
        force = kl * np.asarray(dead_band(x - s[:, 0], b))
    base = np.asarray(law.base(x, v))
    return Simulation(t, {"displacement": x, "velocity": v, "force": force}, base, force - base)


@dataclass
class Controller:
    """PD position loop with feedforward: ``u = m_ff r'' + c_ff r' + kp e + kd e'``."""

    kp: float
    kd: float
    m_ff: float
    c_ff: float


def simulate_guide(
    m: float,
    law: ForceLaw,
    path: MinJerkPath,
    ctrl: Controller,
    t: np.ndarray,
    centre: float,
    backlash: Backlash | None = None,
) -> Simulation:
    """The guide: mass ``m`` [kg], resistance ``law`` (``law.c`` the viscous coefficient,
    stroke measured from ``centre`` [m]), tracking ``path`` under ``ctrl``."""
    p0 = path.waypoints[0]

    def motor(tt: float, x: float, v: float) -> float:
        r, rd, rdd = path.at(tt)
        return ctrl.m_ff * rdd + ctrl.c_ff * rd + ctrl.kp * (r - x) + ctrl.kd * (rd - v)

    if backlash is None:

        def rhs(tt: float, y: np.ndarray) -> np.ndarray:
            x, v = y[0], y[1]
            u = motor(tt, x, v)
            res = law.total1(float(x - centre), float(v), float(y[2]) if law.n_states else 0.0)
            out = [v, (u - res) / m]
            if law.n_states:
                out.extend(law.state_rate(x - centre, v, y[2:]))
            return np.array(out)

        kinds = ["pos", "vel", *_law_state_kind(law)]
        y = integrate(
            rhs, np.array([p0, 0.0] + [0.0] * law.n_states), t, rtol=RTOL, atol=_atol(kinds)
        )
        x, v = y[:, 0], y[:, 1]
        u = np.array(
            [motor(float(tt), float(a), float(b)) for tt, a, b in zip(t, x, v, strict=True)]
        )
        res = law.total(x - centre, v, y[:, 2] if law.n_states else 0.0)
        acc = (u - res) / m
    else:
        mm = backlash.motor_fraction * m
        mc = m - mm
        b, kl, cl = backlash.gap, backlash.k, backlash.c
        width = 0.02 * b

        def link(y: np.ndarray) -> float:
            delta = y[0] - y[2]
            return kl * float(dead_band(delta, b)) + cl * (y[1] - y[3]) * contact(delta, b, width)

        def rhs_b(tt: float, y: np.ndarray) -> np.ndarray:
            u = motor(tt, y[0], y[1])
            fl = link(y)
            return np.array([y[1], (u - fl) / mm, y[3], (fl - law.c * y[3]) / mc])

        y = integrate(
            rhs_b,
            np.array([p0, 0.0, p0, 0.0]),
            t,
            rtol=RTOL,
            atol=_atol(["pos", "vel", "pos", "vel"]),
        )
        x, v = y[:, 0], y[:, 1]
        u = np.array(
            [motor(float(tt), float(a), float(b_)) for tt, a, b_ in zip(t, x, v, strict=True)]
        )
        fl = np.array([link(row) for row in y])
        acc = (u - fl) / mm
    base = m * acc + law.c * v
    return Simulation(
        t, {"position": x, "velocity": v, "acceleration": acc, "force": u}, base, u - base
    )


@dataclass
class QuarterCar:
    """Masses [kg], suspension stiffness/damping [N/m, N s/m], tyre stiffness [N/m]."""

    m_s: float
    m_u: float
    k_s: float
    c_s: float
    k_t: float


def simulate_quarter_car(
    qc: QuarterCar,
    law: ForceLaw,
    road: SumOfSines,
    t: np.ndarray,
    actuator: SumOfSines | None = None,
    backlash: Backlash | None = None,
) -> Simulation:
    """The quarter car on a shaker; ``law`` is the suspension force (``k = k_s``,
    ``c = c_s``); with ``backlash`` the damper acts through free play."""
    ms, mu, kt = qc.m_s, qc.m_u, qc.k_t
    h = float(t[1] - t[0]) / 8.0
    road_tab = Tabulated(road, float(t[-1]), h)
    act_tab = Tabulated(actuator, float(t[-1]), h) if actuator is not None else None
    plain = law.label is None

    def forces(tt: float, y: np.ndarray) -> tuple[float, float]:
        d, dd = y[2] - y[0], y[3] - y[1]
        if backlash is not None:
            f = qc.k_s * d + backlash.k * float(dead_band(d - y[4], backlash.gap))
        elif plain:
            f = qc.k_s * d + qc.c_s * dd
        else:
            f = law.total1(float(d), float(dd), float(y[4]) if law.n_states else 0.0)
        fa = act_tab.at(tt) if act_tab is not None else 0.0
        return f, fa

    def rhs(tt: float, y: np.ndarray) -> np.ndarray:
        f, fa = forces(tt, y)
        r = road_tab.at(tt)
        out = [y[1], (f + fa) / ms, y[3], (-f - fa + kt * (r - y[2])) / mu]
        d, dd = y[2] - y[0], y[3] - y[1]
        if backlash is not None:
            out.append(backlash.k * float(dead_band(d - y[4], backlash.gap)) / qc.c_s)
        elif law.n_states:
            out.extend(law.state_rate(d, dd, y[4:]))
        return np.array(out)

    kinds = ["pos", "vel", "pos", "vel"]
    kinds += ["pos"] if backlash is not None else _law_state_kind(law)
    y0 = np.zeros(len(kinds))
    y = integrate(rhs, y0, t, rtol=RTOL_QC, atol=10 * _atol(kinds), max_step=0.01)
    d, dd = y[:, 2] - y[:, 0], y[:, 3] - y[:, 1]
    if backlash is None:
        f = law.total(d, dd, y[:, 4] if law.n_states else 0.0)
    else:
        f = qc.k_s * d + backlash.k * np.asarray(dead_band(d - y[:, 4], backlash.gap))
    fa = actuator.evaluate(t) if actuator is not None else np.zeros_like(t)
    r = road.evaluate(t)
    acc = (f + fa) / ms
    base = qc.k_s * d + qc.c_s * dd
    chans = {"road": r, "body_acceleration": acc, "suspension_deflection": d}
    if actuator is not None:
        chans["actuator_force"] = fa
    return Simulation(t, chans, base, f - base, {"tyre_force": kt * (r - y[:, 2])})
