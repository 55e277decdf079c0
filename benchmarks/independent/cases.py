"""Cases: the draw of a device, its test, one concealed effect and its magnitude.

Per family and seed there are four cases: ``control`` (no effect), two ``single`` cases
(two different in-library labels from the device's plausible list) and one ``outside``
(an out-of-library label). Their ids are ``{family}-control-{seed}``,
``{family}-single1-{seed}``, ``{family}-single2-{seed}`` and ``{family}-outside-{seed}``.
Every case draws from its own ``numpy.random.Generator`` seeded with
``(seed, crc32(family), kind code, slot)``, so a case is the same whatever else is made.

Labels: the two singles take consecutive entries of the family's plausible list (in a
fixed family-specific order) indexed by the seed, so consecutive seeds cover the list; the
MR damper's singles are ``hysteresis`` and one other label (half of its singles are
``hysteresis``). The outside label cycles through the out-of-library labels with the seed.
Controls cycle the noise kind white -> coloured -> drift with the seed; singles and
outside cases carry white noise.

Plausible lists (:data:`PLAUSIBLE`): a constant force offset is left out for the dampers
(the gas / accumulator force ``f0`` absorbs it) and a force gain error for the dampers and
the guide (every base term is linear in the force, so a gain only rescales ``c``, ``k``,
``f0`` or ``m``); the quarter car's known masses make a sensor gain visible there.

Recording: the noise-free channels are turned to the declared signs (``positive_stroke``,
``positive_force``), a sensor effect acts on the recorded channel, then the noise is added;
measured displacements / positions carry a few micrometres of noise and velocities /
accelerations are Savitzky-Golay derivatives of them; about a quarter of the cases declare
non-SI units (:data:`UNIT_SETS`).

Magnitude: each effect's target ratio ``rho ~ U(0.05, 0.25)`` is drawn first. For a force
effect, ``rho = rms(effect force) / rms(base force)`` along the simulated trajectory (rms
about zero; devices.py defines both forces); for a sensor effect (offset, gain, lag,
delay) ``rho = rms(measured - true) / rms(true)`` of the affected channel. The effect's
magnitude parameter is found by a log-secant iteration on the simulated ratio (at most a
few simulations); the truth holds the target and the achieved ratio.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from benchmarks.independent.devices import (
    Backlash,
    Controller,
    QuarterCar,
    Simulation,
    simulate_component,
    simulate_guide,
    simulate_quarter_car,
)
from benchmarks.independent.effects import (
    IN_LIBRARY,
    MODEL_TEXT,
    OUTSIDE,
    SCALE_PARAM,
    STATEFUL,
    ForceLaw,
)
from benchmarks.independent.integrate import delayed, first_order_lag, integrate
from benchmarks.independent.noise import NOISE_KINDS, add_noise, sg_derivative
from benchmarks.independent.signals import MinJerkPath, SineBlocks, SumOfSines

FAMILIES = ("damper", "mr_damper", "friction_guide", "quarter_car_rig")
KIND_CODE = {"control": 0, "single": 1, "outside": 2}
MAX_SAMPLES = 40_000
G = 9.80665

#: in-library labels a user of each device could meet
PLAUSIBLE: dict[str, tuple[str, ...]] = {
    "damper": (
        "friction",
        "hysteresis",
        "digressive",
        "damper_asymmetry",
        "viscoelastic",
        "end_stop",
        "sensor_lag",
    ),
    "mr_damper": (
        "hysteresis",
        "friction",
        "digressive",
        "damper_asymmetry",
        "viscoelastic",
        "sensor_lag",
    ),
    "friction_guide": (
        "friction",
        "hysteresis",
        "damper_asymmetry",
        "progressive",
        "sensor_offset",
        "sensor_lag",
    ),
    "quarter_car_rig": (
        "friction",
        "hysteresis",
        "digressive",
        "damper_asymmetry",
        "progressive",
        "end_stop",
        "viscoelastic",
        "sensor_offset",
        "sensor_gain",
        "sensor_lag",
    ),
}
assert all(set(v) <= set(IN_LIBRARY) for v in PLAUSIBLE.values())

TEST_NAME = {
    "damper": "dyno_sine",
    "mr_damper": "shaking_table_sine",
    "friction_guide": "guide_trajectory",
    "quarter_car_rig": "quarter_car_shaker",
}

#: declared unit sets used in about a quarter of the cases (channel -> unit)
UNIT_SETS: dict[str, list[dict[str, str]]] = {
    "damper": [
        {"displacement": "mm", "velocity": "mm/s", "force": "N"},
        {"displacement": "in", "velocity": "in/s", "force": "lbf"},
        {"displacement": "mm", "velocity": "mm/s", "force": "kN"},
        {"displacement": "cm", "velocity": "m/s", "force": "N"},
    ],
    "friction_guide": [
        {"position": "mm", "velocity": "mm/s", "force": "N"},
        {"position": "mm", "velocity": "mm/s", "force": "lbf"},
    ],
    "quarter_car_rig": [
        {"road": "mm", "suspension_deflection": "mm", "actuator_force": "kN"},
        {"road": "in", "suspension_deflection": "in", "actuator_force": "lbf"},
        {"road": "cm", "suspension_deflection": "mm", "actuator_force": "N"},
    ],
}
UNIT_SETS["mr_damper"] = UNIT_SETS["damper"]
SI_UNIT = {
    "displacement": "m",
    "velocity": "m/s",
    "force": "N",
    "coil_voltage": "V",
    "position": "m",
    "acceleration": "m/s^2",
    "road": "m",
    "actuator_force": "N",
    "body_acceleration": "m/s^2",
    "suspension_deflection": "m",
}


@dataclass(frozen=True)
class CaseSpec:
    """One case to make."""

    family: str
    seed: int
    kind: str
    slot: int
    label: str | None

    @property
    def case_id(self) -> str:
        kind = self.kind if self.kind != "single" else f"single{self.slot}"
        return f"{self.family}-{kind}-{self.seed}"


@dataclass
class Case:
    """A made case: SI channels with the declared signs, declared units, meta, truth."""

    spec: CaseSpec
    time: np.ndarray
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    units: dict[str, str]
    meta: dict[str, Any]
    truth: dict[str, Any]


def _crc(text: str) -> int:
    return zlib.crc32(text.encode())


def plan(family: str, seed: int) -> list[CaseSpec]:
    """The four cases of ``family`` for ``seed``."""
    order = list(PLAUSIBLE[family])
    if family == "mr_damper":
        rest = order[1:]
        other = rest[seed % len(rest)]
        pair = ["hysteresis", other] if seed % 2 == 0 else [other, "hysteresis"]
    else:
        np.random.default_rng(_crc(family)).shuffle(order)
        n = len(order)
        i = (2 * seed) % n
        pair = [order[i], order[(i + 1) % n]]
    out_label = OUTSIDE[(seed + FAMILIES.index(family)) % len(OUTSIDE)]
    return [
        CaseSpec(family, seed, "control", 0, None),
        CaseSpec(family, seed, "single", 1, pair[0]),
        CaseSpec(family, seed, "single", 2, pair[1]),
        CaseSpec(family, seed, "outside", 0, out_label),
    ]


def rng_for(spec: CaseSpec) -> np.random.Generator:
    """The case's generator, seeded from (seed, family, kind, slot)."""
    return np.random.default_rng([spec.seed, _crc(spec.family), KIND_CODE[spec.kind], spec.slot])


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def calibrate(
    ratio_of: Callable[[float], tuple[float, Any]],
    start: float,
    target: float,
    bounds: tuple[float, float],
    iters: int = 5,
    tol: float = 0.12,
) -> tuple[float, float, Any]:
    """Magnitude ``s`` with ``ratio_of(s)[0]`` near ``target``: log-secant steps from
    ``start`` within ``bounds``. Returns ``(s, ratio, payload)`` of the closest try."""
    tries: list[tuple[float, float, Any]] = []
    s = min(max(start, bounds[0]), bounds[1])
    for _ in range(iters):
        r, payload = ratio_of(s)
        tries.append((s, r, payload))
        if r > 0 and abs(r / target - 1.0) < tol:
            break
        slope = 1.0
        if len(tries) >= 2:
            (s1, r1, _), (s2, r2, _) = tries[-2], tries[-1]
            if r1 > 0 and r2 > 0 and s1 != s2 and r1 != r2:
                slope = min(max(math.log(r2 / r1) / math.log(s2 / s1), 0.2), 3.0)
        nxt = s * 4.0 if r <= 0 else s * (target / r) ** (1.0 / slope)
        nxt = min(max(nxt, bounds[0]), bounds[1])
        if nxt == s:
            break
        s = nxt
    return min(tries, key=lambda e: abs(math.log(max(e[1], 1e-12) / target)))


# --------------------------------------------------------------------------- effects
def draw_shape(
    rng: np.random.Generator, label: str, family: str, ctx: dict[str, float]
) -> tuple[str, dict[str, float]]:
    """Variant and shape parameters of a force effect (its magnitude set later).

    ``ctx``: ``v_peak`` [m/s], ``x_rms`` [m], ``c`` [N s/m] of the element, ``dt`` [s],
    and stop ``gap`` candidates ``gap_bump`` / ``gap_rebound`` [m].
    """
    vp = ctx["v_peak"]
    if label == "friction":
        if family == "mr_damper":
            return "bingham", {"vs": float(rng.uniform(0.5e-3, 10e-3))}
        variant = str(rng.choice(["tanh", "stribeck", "lugre"]))
        p = {"vs": float(rng.uniform(0.5e-3, 10e-3))}
        if variant != "tanh":
            p["fs_ratio"] = float(rng.uniform(1.2, 2.0))
            p["vst"] = float(rng.uniform(5e-3, 50e-3))
        if variant == "lugre":
            p["x_pre"] = float(rng.uniform(0.02e-3, 0.2e-3))
            p["tau_b"] = float(rng.uniform(0.1e-3, 1e-3))
            del p["vs"]
        return variant, p
    if label == "hysteresis":
        zy = (
            rng.uniform(0.05e-3, 0.5e-3)
            if family == "friction_guide"
            else rng.uniform(0.3e-3, 3e-3)
        )
        n = float(rng.uniform(1.0, 3.0))
        A = float(rng.uniform(0.8, 1.2))
        share = float(rng.uniform(0.55, 1.0))
        s = A / zy**n
        return ("bouc_wen_mr" if family == "mr_damper" else "bouc_wen"), {
            "A": A,
            "beta": s * share,
            "gamma": s * (1.0 - share),
            "n": n,
            "z_yield": float(zy),
        }
    if label == "digressive":
        variant = str(rng.choice(["tanh", "two_slope"]))
        return variant, {"vk": float(rng.uniform(0.1, 0.4) * vp)}
    if label == "damper_asymmetry":
        return "one_side", {"side": float(rng.choice([-1.0, 1.0]))}
    if label == "viscoelastic":
        return "maxwell", {"tau": float(rng.uniform(2e-3, 30e-3))}
    if label == "progressive":
        return "cubic", {}
    if label == "end_stop":
        u = rng.random()
        bump, rebound = (1.0, 0.0) if u < 0.6 else ((0.0, 1.0) if u < 0.8 else (1.0, 1.0))
        gap = ctx["gap_bump"] if bump else ctx["gap_rebound"]
        if bump and rebound:
            gap = max(ctx["gap_bump"], ctx["gap_rebound"])
        return "linear", {"bump": bump, "rebound": rebound, "gap": gap}
    if label == "cubic_damper":
        return "cubic", {}
    if label == "velocity_dead_zone":
        return "dead_band", {}
    raise ValueError(f"no force law for {label!r}")


def initial_magnitude(
    label: str, p: dict[str, float], target: float, base_rms: float, ctx: dict[str, float]
) -> tuple[float, tuple[float, float]]:
    """A first guess of the magnitude parameter and its bounds."""
    f = target * base_rms
    vp, xr, c = ctx["v_peak"], ctx["x_rms"], ctx["c"]
    if label == "friction":
        return f, (1e-6 * f, 100 * f)
    if label == "hysteresis":
        zs = (p["A"] / (p["beta"] + p["gamma"])) ** (1.0 / p["n"])
        return f / zs, (1e-6 * f / zs, 100 * f / zs)
    if label in ("digressive",):
        return 0.5 * c, (1e-4 * c, 0.9 * c)
    if label == "damper_asymmetry":
        return 2 * f / (0.7 * vp), (1e-4 * c, 5.0 * c)
    if label == "viscoelastic":
        return f / (0.7 * vp * p["tau"]), (1e-6, 1e12)
    if label == "progressive":
        return f / (3 * xr**3), (1e-6, 1e15)
    if label == "end_stop":
        return 10 * f / max(xr, 1e-6), (1e-3, 1e12)
    if label == "cubic_damper":
        return f / (0.4 * vp**3), (1e-6, 1e12)
    if label == "velocity_dead_zone":
        return target * vp, (1e-6, 0.9 * vp)
    if label == "backlash":
        return ctx.get("gap_per_ratio", 0.3 * xr) * target, (1e-7, xr)
    raise ValueError(label)


def sensor_apply(
    label: str, y: np.ndarray, t: np.ndarray, value: float, sign: float = 1.0
) -> np.ndarray:
    """The channel ``y`` as a sensor with the effect ``label`` reports it."""
    if label == "sensor_offset":
        return y + sign * value
    if label == "sensor_gain":
        return y * (1.0 + sign * value)
    if label == "sensor_lag":
        return first_order_lag(y, float(t[1] - t[0]), value)
    if label == "time_delay":
        return delayed(y, t, value)
    raise ValueError(label)


def sensor_effect(
    rng: np.random.Generator, label: str, y: np.ndarray, t: np.ndarray, target: float
) -> tuple[np.ndarray, dict[str, float], float]:
    """Apply a sensor effect with rms error ``target * rms(y)``; returns the measured
    channel, the parameters and the achieved ratio."""
    ref = _rms(y)
    dt = float(t[1] - t[0])
    if label in ("sensor_offset", "sensor_gain"):
        sign = float(rng.choice([-1.0, 1.0]))
        value = target * ref if label == "sensor_offset" else target
        out = sensor_apply(label, y, t, value, sign)
        key = SCALE_PARAM[label]
        return out, {key: sign * value}, _rms(out - y) / ref

    def ratio(v: float) -> tuple[float, np.ndarray]:
        o = sensor_apply(label, y, t, v)
        return _rms(o - y) / ref, o

    s, r, out = calibrate(ratio, 5 * dt, target, (0.05 * dt, 2.0), iters=12, tol=0.02)
    return out, {SCALE_PARAM[label]: s}, r


# --------------------------------------------------------------------------- devices
@dataclass
class Draw:
    """What a device draw produced before noise."""

    sim: Simulation
    base: dict[str, Any]
    excitation: dict[str, Any]
    effect: dict[str, Any] | None
    known: dict[str, float]


def _effect_record(
    label: str,
    variant: str,
    params: dict[str, Any],
    target: float,
    achieved: float,
    definition: str,
) -> dict[str, Any]:
    return {
        "label": label,
        "in_library": label in IN_LIBRARY,
        "params": {
            **params,
            "variant": variant,
            "magnitude_parameter": SCALE_PARAM[label],
            "target_ratio": target,
            "achieved_ratio": achieved,
            "ratio_definition": definition,
            "magnitude_draw": "target ratio ~ U(0.05, 0.25); magnitude parameter solved "
            "on the simulated ratio",
        },
        "model": MODEL_TEXT[(label, variant)],
    }


FORCE_RATIO = "rms(effect force) / rms(base force) along the simulated trajectory"
SENSOR_RATIO = "rms(measured - true) / rms(true) of the affected channel (noise-free)"


def _force_effect(
    rng: np.random.Generator,
    label: str,
    family: str,
    target: float,
    base_sim: Simulation,
    law0: ForceLaw,
    run: Callable[[ForceLaw, Backlash | None], Simulation],
    ctx: dict[str, float],
    backlash_of: Callable[[float], Backlash] | None = None,
    iters: int = 5,
    pre: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[Simulation, dict[str, Any]]:
    """Calibrate a force effect; returns the simulation and the truth record."""
    base_rms = _rms(base_sim.base_force)
    if label == "backlash":
        assert backlash_of is not None
        start, bounds = initial_magnitude(label, {}, target, base_rms, ctx)

        def ratio_b(g: float) -> tuple[float, Simulation]:
            sim = run(law0, backlash_of(g))
            return _rms(sim.effect_force) / _rms(sim.base_force), sim

        g, r, sim = calibrate(ratio_b, start, target, bounds, iters=iters)
        bl = backlash_of(g)
        params: dict[str, Any] = {"gap": g, "contact_stiffness": bl.k}
        if family == "friction_guide":
            params.update({"contact_damping": bl.c, "motor_mass_fraction": bl.motor_fraction})
        return sim, _effect_record(label, "free_play", params, target, r, FORCE_RATIO)
    variant, p = draw_shape(rng, label, family, ctx)
    key = SCALE_PARAM[label]
    start, bounds = initial_magnitude(label, p, target, base_rms, ctx)

    def ratio(s: float) -> tuple[float, Simulation]:
        law = ForceLaw(law0.f0, law0.k, law0.c, label, variant, {**p, key: s})
        sim = run(law, None)
        return _rms(sim.effect_force) / _rms(sim.base_force), sim

    if pre is not None:
        # a first magnitude from the effect force along the effect-free trajectory
        def ratio_pre(s: float) -> tuple[float, None]:
            law = ForceLaw(law0.f0, law0.k, law0.c, label, variant, {**p, key: s})
            state = _state_along(law, base_sim.t, pre[0], pre[1])
            return _rms(law.effect(pre[0], pre[1], state)) / base_rms, None

        iters_pre = 3 if (label, variant) in STATEFUL else 12
        start = calibrate(ratio_pre, start, target, bounds, iters=iters_pre, tol=0.01)[0]
    s, r, sim = calibrate(ratio, start, target, bounds, iters=iters)
    return sim, _effect_record(label, variant, {**p, key: s}, target, r, FORCE_RATIO)


def _state_along(law: ForceLaw, t: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The effect's state along a sampled stroke ``x`` [m] and rate ``v`` [m/s] (linear
    between samples), or 0.0 for a memoryless effect."""
    if not law.n_states:
        return np.zeros_like(x)
    dt = float(t[1] - t[0])
    n = x.size - 1

    def rhs(tt: float, s: np.ndarray) -> np.ndarray:
        u = min(max(tt / dt, 0.0), float(n))
        i = min(int(u), n - 1)
        f = u - i
        xx = x[i] + f * (x[i + 1] - x[i])
        vv = v[i] + f * (v[i + 1] - v[i])
        return law.state_rate(float(xx), float(vv), s)

    return integrate(rhs, np.zeros(1), t - t[0], rtol=1e-6, atol=1e-9)[:, 0]


def _dt(rng: np.random.Generator, duration: float, choices: tuple[float, ...]) -> float:
    dt = float(rng.choice(choices))
    while duration / dt > MAX_SAMPLES:
        dt *= 2.0
    return dt


def _time(duration: float, dt: float) -> np.ndarray:
    return np.arange(int(duration / dt) + 1) * dt


def draw_damper(rng: np.random.Generator, label: str | None, mr: bool) -> Draw:
    """Damper on a dyno (``mr=False``) or MR damper on a shaking table (``mr=True``).

    Damper: ``c ~ U(1000, 3500)`` N s/m, ``f_gas ~ U(50, 300)`` N, ``k_gas ~ U(1, 5)`` kN/m;
    sines at two amplitudes (``a_hi ~ U(25, 50)`` mm, ``a_lo = a_hi U(0.35, 0.55)``) and
    three frequencies (top speed ``U(0.3, 0.6)`` m/s), 3-5 cycles each. MR damper: coil
    voltage ``U(0.5, 4.5)`` V, ``c = c0 + c1 V`` (``c0 ~ U(300, 900)``, ``c1 ~ U(100, 400)``),
    ``k ~ U(0.5, 3)`` kN/m, ``f0 ~ U(20, 150)`` N; four sine blocks of 5-20 mm at 0.5-3 Hz.
    Sampling 1 kHz or 500 Hz (at most :data:`MAX_SAMPLES` samples).
    """
    family = "mr_damper" if mr else "damper"
    if mr:
        volts = float(rng.uniform(0.5, 4.5))
        c0, c1 = float(rng.uniform(300, 900)), float(rng.uniform(100, 400))
        k, f0 = float(rng.uniform(500, 3000)), float(rng.uniform(20, 150))
        c = c0 + c1 * volts
        base = {"c0": c0, "c1": c1, "coil_voltage": volts, "c": c, "k": k, "f0": f0}
        blocks = []
        for _ in range(4):
            amp = float(rng.uniform(5e-3, 20e-3))
            f = float(rng.uniform(0.5, 3.0))
            blocks.append((amp, f, int(rng.integers(3, 6))))
        blocks.sort(key=lambda b: b[0] * b[1])
    else:
        c = float(rng.uniform(1000, 3500))
        k, f0 = float(rng.uniform(1000, 5000)), float(rng.uniform(50, 300))
        base = {"c": c, "f_gas": f0, "k_gas": k}
        vmax = float(rng.uniform(0.3, 0.6))
        a_hi = float(rng.uniform(0.025, 0.05))
        a_lo = a_hi * float(rng.uniform(0.35, 0.55))
        f_hi = vmax / (2 * math.pi * a_hi)
        freqs = [max(f_hi * rng.uniform(0.2, 0.3), 0.35), f_hi * rng.uniform(0.45, 0.6), f_hi]
        blocks = [
            (a, float(f), n) for a in (a_lo, a_hi) for f, n in zip(freqs, (3, 4, 5), strict=True)
        ]
    exc = SineBlocks(blocks, rest=0.3)
    dt = _dt(rng, exc.duration, (1e-3, 2e-3))
    t = _time(exc.duration, dt)
    law0 = ForceLaw(f0, k, c)

    def run(law: ForceLaw, bl: Backlash | None) -> Simulation:
        return simulate_component(law, exc, t, bl)

    sim = run(law0, None)
    x, v = sim.channels["displacement"], sim.channels["velocity"]
    ctx = {
        "v_peak": float(np.max(np.abs(v))),
        "x_rms": _rms(x),
        "c": c,
        "dt": dt,
        "gap_bump": float(np.quantile(x[x > 0], rng.uniform(0.85, 0.95))),
        "gap_rebound": float(np.quantile(-x[x < 0], rng.uniform(0.85, 0.95))),
    }
    effect = None
    if label is not None and label not in ("sensor_lag", "time_delay"):
        target = float(rng.uniform(0.05, 0.25))
        kl = c / float(rng.uniform(0.1e-3, 0.3e-3))
        sim, effect = _force_effect(
            rng,
            label,
            family,
            target,
            sim,
            law0,
            run,
            ctx,
            backlash_of=lambda g: Backlash(g, kl),
        )
        if mr and label == "hysteresis":
            _split_field(rng, effect, "alpha", volts)
        if mr and label == "friction":
            _split_field(rng, effect, "Fc", volts)
    return Draw(sim, base, exc.describe(), effect, {})


def _split_field(rng: np.random.Generator, effect: dict[str, Any], key: str, volts: float) -> None:
    """Write an MR parameter's value at the coil voltage as ``p0 + p1 V``."""
    val = effect["params"][key]
    share = float(rng.uniform(0.5, 0.9))
    effect["params"][key + "0"] = val * (1.0 - share)
    effect["params"][key + "1"] = val * share / volts
    effect["params"]["field_dependence"] = f"{key} = {key}0 + {key}1 * coil_voltage"


def draw_guide(rng: np.random.Generator, label: str | None) -> Draw:
    """A carriage on a guide under a position loop.

    ``m ~ U(5, 40)`` kg; 8-12 alternating minimum-jerk moves over a travel of 0.1-0.3 m at
    peak speeds 0.1-0.4 m/s; ``c`` set so that ``c rms(v)`` is 0.3-1.2 times ``m rms(a)``;
    PD loop with crossover 8-20 Hz, damping ratio 0.7-1, feedforward within 10 %.
    """
    m = float(rng.uniform(5.0, 40.0))
    length = float(rng.uniform(0.1, 0.3))
    v_peak = float(rng.uniform(0.1, 0.4))
    n_moves = int(rng.integers(8, 13))
    way = [float(rng.uniform(0.0, 0.3) * length)]
    durs, dwell = [], [float(rng.uniform(0.1, 0.3))]
    for i in range(n_moves):
        lo, hi = (0.5, 1.0) if i % 2 == 0 else (0.0, 0.5)
        way.append(float(rng.uniform(lo, hi) * length))
        durs.append(max(1.875 * abs(way[-1] - way[-2]) / v_peak, 0.3))
        dwell.append(float(rng.uniform(0.05, 0.3)))
    path = MinJerkPath(way, durs, dwell)
    dt = _dt(rng, path.duration, (1e-3, 1e-3, 2e-3))
    t = _time(path.duration, dt)
    _, rv, ra = path.evaluate(t)
    c = float(rng.uniform(0.3, 1.2) * m * _rms(ra) / _rms(rv))
    wc = 2 * math.pi * float(rng.uniform(8.0, 20.0))
    zeta = float(rng.uniform(0.7, 1.0))
    m_ff = m * float(rng.uniform(0.9, 1.1))
    ctrl = Controller(m_ff * wc * wc, 2 * zeta * m_ff * wc, m_ff, c * float(rng.uniform(0.9, 1.1)))
    centre = 0.5 * length
    base = {
        "m": m,
        "c": c,
        "kp": ctrl.kp,
        "kd": ctrl.kd,
        "m_ff": m_ff,
        "c_ff": ctrl.c_ff,
        "centre": centre,
    }
    law0 = ForceLaw(0.0, 0.0, c)

    def run(law: ForceLaw, bl: Backlash | None) -> Simulation:
        return simulate_guide(m, law, path, ctrl, t, centre, bl)

    sim = run(law0, None)
    x, v = sim.channels["position"] - centre, sim.channels["velocity"]
    ctx = {
        "v_peak": float(np.max(np.abs(v))),
        "x_rms": _rms(x),
        "c": c,
        "dt": dt,
        "gap_bump": 0.0,
        "gap_rebound": 0.0,
        "gap_per_ratio": 1e-4,  # impacts in the stiff drive make a small play visible
    }
    effect = None
    if label is not None and label not in ("sensor_lag", "time_delay", "sensor_offset"):
        target = float(rng.uniform(0.05, 0.25))
        frac = float(rng.uniform(0.2, 0.4))
        mc = (1 - frac) * m
        kl = mc * (2 * math.pi * float(rng.uniform(80.0, 150.0))) ** 2
        cl = 2 * 0.2 * math.sqrt(kl * frac * mc * m / m)
        sim, effect = _force_effect(
            rng,
            label,
            "friction_guide",
            target,
            sim,
            law0,
            run,
            ctx,
            backlash_of=lambda g: Backlash(g, kl, cl, frac),
            iters=5,
            pre=(x, v),
        )
    return Draw(sim, base, {**path.describe(), "controller": "PD with feedforward"}, effect, {})


def _unit_sines(
    rng: np.random.Generator, n: int, band: tuple[float, float], tilt: float, duration: float
) -> SumOfSines:
    f = np.exp(rng.uniform(math.log(band[0]), math.log(band[1]), n))
    amps = f**-tilt * rng.uniform(0.5, 1.5, n)
    phases = rng.uniform(0, 2 * math.pi, n)
    sig = SumOfSines(amps, 2 * math.pi * f, phases, duration, ramp=1.0)
    tt = np.linspace(1.0, duration - 1.0, 2000)
    sig.amps = amps / float(np.std(sig.evaluate(tt)))
    return sig


def _scaled(sim: Simulation, s: float) -> Simulation:
    return Simulation(
        sim.t,
        {k: v * s for k, v in sim.channels.items()},
        sim.base_force * s,
        sim.effect_force * s,
        {k: v * s for k, v in sim.extra.items()},
    )


def draw_quarter_car(rng: np.random.Generator, label: str | None) -> Draw:
    """A quarter car on a shaker (random or swept road with bumps, optional actuator).

    ``m_s ~ U(200, 450)`` kg, ``m_u ~ U(25, 60)`` kg, body frequency 1-1.6 Hz, damping ratio
    0.2-0.4, wheel-hop frequency 9-13 Hz; road: 40 random-phase sines over 0.5-15 Hz
    (displacement ~ 1/f) or a log sweep from 0.5 Hz to 10-15 Hz, plus 2-5 raised-cosine
    bumps; scaled for a deflection std of 8-18 mm, then down if the dynamic tyre force would
    exceed 0.8 of the static load (no lift-off). Actuator force in a third of the cases:
    random-phase sines over 0.5-8 Hz, std 0.3-1 of ``k_s`` times the deflection target.
    """
    ms, mu = float(rng.uniform(200, 450)), float(rng.uniform(25, 60))
    fb, fw = float(rng.uniform(1.0, 1.6)), float(rng.uniform(9.0, 13.0))
    ks = ms * (2 * math.pi * fb) ** 2
    cs = 2 * float(rng.uniform(0.2, 0.4)) * math.sqrt(ks * ms)
    kt = max(mu * (2 * math.pi * fw) ** 2 - ks, 5 * ks)
    qc = QuarterCar(ms, mu, ks, cs, kt)
    duration = float(rng.uniform(20.0, 28.0))
    if rng.random() < 0.5:
        road = _unit_sines(rng, 40, (0.5, 15.0), 1.0, duration)
    else:
        f1 = float(rng.uniform(10.0, 15.0))
        road = SumOfSines(
            np.zeros(0),
            np.zeros(0),
            np.zeros(0),
            duration,
            ramp=1.0,
            sweep=(0.5, f1, 1.0, 1.0 / (2 * math.pi * 1.0)),
        )
    nb = int(rng.integers(2, 6))
    starts = np.sort(rng.uniform(2.0, duration - 2.0, nb))
    road.bumps = [
        (
            float(s),
            float(rng.uniform(0.12, 0.4)),
            float(rng.choice([-1, 1]) * rng.uniform(1.0, 2.5)),
        )
        for s in starts
    ]
    if road.sweep is not None:
        tt = np.linspace(1.0, duration - 1.0, 2000)
        road.scale = 1.0 / float(np.std(road.evaluate(tt)))
    actuator = None
    if rng.random() < 1.0 / 3.0:
        actuator = _unit_sines(rng, 30, (0.5, 8.0), 0.0, duration)
    dt = _dt(rng, duration, (2e-3, 2e-3, 1e-3))
    t = _time(duration, dt)
    law0 = ForceLaw(0.0, ks, cs)
    defl_target = float(rng.uniform(8e-3, 18e-3))
    sim = simulate_quarter_car(qc, law0, road, t)
    s = defl_target / float(np.std(sim.channels["suspension_deflection"]))
    road.scale *= s
    sim = _scaled(sim, s)
    if actuator is not None:
        actuator.scale = float(rng.uniform(0.3, 1.0)) * ks * defl_target
        sim = simulate_quarter_car(qc, law0, road, t, actuator)
    static = (ms + mu) * G
    worst = -float(np.min(sim.extra["tyre_force"]))
    if worst > 0.8 * static:  # keep the tyre on the plate: scale every input down
        s = 0.8 * static / worst
        road.scale *= s
        if actuator is not None:
            actuator.scale *= s
        sim = _scaled(sim, s)
    base = {"m_s": ms, "m_u": mu, "k_s": ks, "c_s": cs, "k_t": kt}
    d, dd = (
        sim.channels["suspension_deflection"],
        np.gradient(sim.channels["suspension_deflection"], dt),
    )
    ctx = {
        "v_peak": float(np.max(np.abs(dd))),
        "x_rms": _rms(d),
        "c": cs,
        "dt": dt,
        "gap_bump": float(np.quantile(d[d > 0], rng.uniform(0.9, 0.97))),
        "gap_rebound": float(np.quantile(-d[d < 0], rng.uniform(0.9, 0.97))),
    }
    effect = None
    if label is not None and label not in (
        "sensor_offset",
        "sensor_gain",
        "sensor_lag",
        "time_delay",
    ):
        target = float(rng.uniform(0.05, 0.25))
        kl = cs / float(rng.uniform(0.5e-3, 2e-3))

        def run(law: ForceLaw, bl: Backlash | None) -> Simulation:
            return simulate_quarter_car(qc, law, road, t, actuator, bl)

        sim, effect = _force_effect(
            rng,
            label,
            "quarter_car_rig",
            target,
            sim,
            law0,
            run,
            ctx,
            backlash_of=lambda g: Backlash(g, kl),
            iters=3,
            pre=(d, dd),
        )
    exc: dict[str, Any] = {"road": road.describe()}
    if actuator is not None:
        exc["actuator_force"] = actuator.describe()
    return Draw(sim, base, exc, effect, {"m_s": ms, "m_u": mu})


# --------------------------------------------------------------------------- assembly
def make_case(spec: CaseSpec) -> Case:
    """Draw, simulate, measure and describe one case."""
    rng = rng_for(spec)
    fam, label = spec.family, spec.label
    if fam in ("damper", "mr_damper"):
        draw = draw_damper(rng, label, fam == "mr_damper")
    elif fam == "friction_guide":
        draw = draw_guide(rng, label)
    elif fam == "quarter_car_rig":
        draw = draw_quarter_car(rng, label)
    else:
        raise ValueError(f"unknown family {fam!r}; families are {FAMILIES}")
    sim, t = draw.sim, draw.sim.t
    dt = float(t[1] - t[0])
    ch = sim.channels

    # declared signs
    if fam == "friction_guide":
        stroke, force = "compression", "compression"
    elif fam == "quarter_car_rig":
        stroke, force = str(rng.choice(["compression", "extension"])), "compression"
    else:
        stroke = str(rng.choice(["compression", "extension"]))
        force = str(rng.choice(["compression", "tension"]))
    s_x = 1.0 if stroke == "compression" else -1.0
    s_f = 1.0 if force == "compression" else -1.0

    # clean recorded outputs (declared signs), then sensor effects, then noise
    if fam == "quarter_car_rig":
        outputs = {
            "body_acceleration": ch["body_acceleration"],
            "suspension_deflection": s_x * ch["suspension_deflection"],
        }
        drift_channel = "suspension_deflection"
    else:
        outputs = {"force": s_f * ch["force"]}
        drift_channel = "force"
    effects = [draw.effect] if draw.effect is not None else []
    if label is not None and draw.effect is None:
        target = float(rng.uniform(0.05, 0.25))
        channel = (
            drift_channel
            if fam != "quarter_car_rig"
            else str(rng.choice(["body_acceleration", "suspension_deflection"]))
        )
        outputs[channel], params, achieved = sensor_effect(rng, label, outputs[channel], t, target)
        variant = (
            "pure"
            if label == "time_delay"
            else ("first_order" if label == "sensor_lag" else "constant")
        )
        rec = _effect_record(
            label, variant, {**params, "channel": channel}, target, achieved, SENSOR_RATIO
        )
        rec["params"]["frame"] = "the recorded channel in its declared sign, SI units"
        effects = [rec]
    if spec.kind == "control":
        noise_kind = NOISE_KINDS[(spec.seed + FAMILIES.index(fam)) % len(NOISE_KINDS)]
    else:
        noise_kind = "white"
    outputs, rms, details = add_noise(rng, t, outputs, noise_kind, drift_channel)

    # inputs as the user has them
    inputs: dict[str, np.ndarray] = {}
    if fam in ("damper", "mr_damper"):
        pos_noise = float(rng.uniform(2e-6, 10e-6))
        xm = s_x * ch["displacement"] + pos_noise * rng.standard_normal(t.size)
        window = 0.01 if fam == "damper" else 0.015
        inputs = {"displacement": xm, "velocity": sg_derivative(xm, dt, window, 1)}
        if fam == "mr_damper":
            inputs["coil_voltage"] = np.full(t.size, draw.base["coil_voltage"])
        rms["displacement"] = pos_noise
        details["velocity"] = f"Savitzky-Golay cubic derivative, {window * 1e3:.0f} ms window"
    elif fam == "friction_guide":
        pos_noise = float(rng.uniform(0.5e-6, 3e-6))
        xm = ch["position"] + pos_noise * rng.standard_normal(t.size)
        window = float(rng.uniform(0.015, 0.03))
        inputs = {
            "position": xm,
            "velocity": sg_derivative(xm, dt, window, 1),
            "acceleration": sg_derivative(xm, dt, window, 2),
        }
        rms["position"] = pos_noise
        details["velocity"] = (
            f"Savitzky-Golay cubic derivatives of the measured position, "
            f"{window * 1e3:.1f} ms window"
        )
    else:
        road_noise = float(rng.uniform(2e-6, 10e-6))
        inputs = {"road": ch["road"] + road_noise * rng.standard_normal(t.size)}
        rms["road"] = road_noise
        if "actuator_force" in ch:
            inputs["actuator_force"] = ch["actuator_force"].copy()

    # declared units: SI, or a user's set in about a quarter of the cases
    units = {name: SI_UNIT[name] for name in [*inputs, *outputs]}
    if rng.random() < 0.25:
        options = UNIT_SETS[fam]
        chosen = options[int(rng.integers(len(options)))]
        units.update({k: u for k, u in chosen.items() if k in units})

    rig: dict[str, Any] = {
        "device": fam,
        "known": draw.known,
        "positive_stroke": stroke,
        "positive_force": force,
    }
    if "actuator_force" in inputs:
        rig["extra_inputs"] = {
            "actuator_force": "force between body and wheel, positive pushing them apart"
        }
    meta = {
        "source": "independent synthetic generator (benchmarks.independent)",
        "sampling": {"dt_s": dt},
        "rig": rig,
    }
    truth = {
        "case_id": spec.case_id,
        "family": fam,
        "seed": spec.seed,
        "kind": spec.kind,
        "slot": spec.slot,
        "base": draw.base,
        "effects": effects,
        "noise": {"kind": noise_kind, "rms": rms, "details": details},
        "units_declared": units,
        "positive_stroke": stroke,
        "positive_force": force,
        "excitation": draw.excitation,
        "n_samples": int(t.size),
        "base_force_rms": _rms(sim.base_force),
        "physical_signs": "devices.py: damper stroke and force positive in compression; "
        "quarter car heights up, deflection positive in compression; guide force along +x",
    }
    return Case(spec, t, inputs, outputs, units, meta, truth)
