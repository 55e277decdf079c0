"""Concealed-effect cases: synthetic "measured" recordings from a richer truth model.

For a component family and a seed, :func:`make_case` builds the family's example
test (its inputs), draws base parameters, zero, one or two effects from the
family's candidate list with random magnitude and shape, and a random noise level,
simulates the truth model and adds the noise. The recording given to the
diagnosis says nothing about what was added; the truth is returned separately
(:class:`Truth`) and written to a separate file by :func:`write_case`.

Magnitudes are drawn relative to the base model's own force, stroke and speed
scales (so an effect is neither invisible nor dominant); units SI. In half of the dyno
and guide cases the motion channels are recorded as rigs record them (a noisy
displacement and its Savitzky-Golay derivatives; :func:`_recorded_motion`), while the
component felt the exact motion.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.diagnosis.component.rig import DRIFT, baseline_families, baseline_model, describe_rig
from suspenv.diagnosis.hypothesis import family_of
from suspenv.measurements import Recording, save_recording
from suspenv.models.components import make_component
from suspenv.models.effects import Effect, make_effect

#: base parameter draws per family: name -> (low, high), uniform
BASE_DRAWS: dict[str, dict[str, tuple[float, float]]] = {
    "damper": {"c": (800.0, 3000.0)},
    "mr_damper": {"c": (500.0, 2500.0), "k": (-2000.0, 2000.0), "f_0": (-20.0, 20.0)},
    "friction_guide": {"m": (60.0, 130.0), "c": (100.0, 300.0)},
    "quarter_car_rig": {"k_s": (15e3, 40e3), "c_s": (800.0, 2500.0), "k_t": (1.5e5, 3e5)},
}

#: effect kinds never concealed in a family (not separable from its base by design)
EXCLUDED: dict[str, tuple[str, ...]] = {
    # LuGre's steady state is Stribeck friction; drawing it adds cost, not a new case
    "friction_guide": ("lugre_friction",),
    # a damper's seal friction is searched for as LuGre, but its cases keep the Coulomb
    # step they were drawn with (the reported seeds keep their cases); the independent
    # generator conceals LuGre seal friction in dampers
    "damper": ("lugre_friction", "bump_and_rebound_stops"),
    # the stop pair is searched for, but the cases keep the one-sided stops they were
    # drawn with (the reported seeds keep their cases); the independent generator
    # conceals stops on both sides, and tests conceal the pair in a quarter car
    "quarter_car_rig": ("bump_and_rebound_stops",),
}

#: options of the family's example test used for its cases (default: the model's own);
#: the quarter car is simulated by a time integrator, so its cases use a shorter run
#: (random road plus the bump, 2.5 s at 2 ms)
CASE_RECORDING_OPTIONS: dict[str, dict[str, float]] = {
    "quarter_car_rig": {"duration": 2.5},
}


@dataclass
class Truth:
    """What was concealed in a case (kept apart from the case file)."""

    case_id: str
    family: str
    seed: int
    base: dict[str, float]
    effects: list[dict[str, Any]]
    noise_rms: float
    noise_fraction: float
    #: the standard baseline's elements the case carries (not concealed effects)
    baseline: list[dict[str, Any]] = field(default_factory=list)
    #: "white", "coloured" or "drift" (:data:`CONTROL_NOISE`)
    noise_kind: str = "white"
    #: the concealed element is outside the effect library
    outside: bool = False
    #: how the rig recorded the motion (:func:`_recorded_motion`); None: exactly
    motion: dict[str, Any] | None = None
    #: the blind user's condition (:data:`CONDITIONS`) and its values; None: none
    condition: dict[str, Any] | None = None

    @property
    def kinds(self) -> list[str]:
        """Concealed library effect kinds (empty for controls and outside cases)."""
        return [] if self.outside else [e["kind"] for e in self.effects]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class Case:
    recording: Recording
    truth: Truth
    extra: dict[str, Any] = field(default_factory=dict)


def _scales(model: Any, base: dict[str, float], rec: Recording) -> dict[str, float]:
    """Force [N], stroke [m], speed [m/s] and angular frequency [rad/s] amplitudes of
    the base model on ``rec`` (the suspension force k x + c v where no force is output),
    and the travel from x = 0 on either side (``bump``: compression, ``rebound``:
    extension; m), where a stop's gap is measured: a quarter car's deflection is not
    centred, and a gap drawn from the centred stroke may lie beyond the travel."""
    from suspenv.diagnosis.component.motion import motion

    sim = model.simulate(model.theta_from(base), rec)
    x, v = motion(rec.with_outputs(sim))
    stroke = float(np.percentile(np.abs(x - np.median(x)), 98))
    speed = float(np.percentile(np.abs(v), 98))
    if "force" in sim:
        f = sim["force"]
        force = float(np.percentile(np.abs(f - np.median(f)), 98))
    else:
        force = base.get("k_s", 0.0) * stroke + base.get("c_s", 0.0) * speed
    y = np.asarray(sim[model.output_channels[0]], float)
    return {
        "force": force,
        # amplitude of the first output channel, in its own unit (sensor offsets)
        "channel": float(np.percentile(np.abs(y - np.median(y)), 98)),
        "stroke": stroke,
        "bump": max(float(np.percentile(x, 98)), 0.0),
        "rebound": max(-float(np.percentile(x, 2)), 0.0),
        "speed": speed,
        "frequency": speed / max(stroke, 1e-12),
    }


def _draw_friction(kind: str, u: Any, mag: float, X: float, V: float) -> dict[str, float]:
    """Parameters of a friction or hysteresis element of size ``mag`` [N] over the stroke
    ``X`` [m] and speed ``V`` [m/s] scales (``u``: the case's uniform draw; empty for
    another kind)."""
    if kind == "coulomb_friction":
        return {"f_c": mag}
    if kind == "directional_friction":
        return {"f_pos": mag, "f_neg": mag * u(0.5, 0.8)}
    if kind == "stribeck_friction":
        return {"f_c": mag, "f_s": mag * u(1.5, 2.5), "v_s": u(0.05, 0.2) * V}
    if kind == "lugre_friction":
        return {
            "f_c": mag,
            "f_s": mag * u(1.3, 2.0),
            "v_s": u(0.05, 0.2) * V,
            "sigma0": mag / (1e-3 * X),
        }
    if kind == "dahl_hysteresis":
        return {"f_c": mag, "sigma": mag / (u(0.03, 0.15) * X)}
    if kind == "bouc_wen_hysteresis":
        return {"f_y": mag, "x_y": u(0.03, 0.15) * X}
    return {}


def draw_effect(kind: str, rng: np.random.Generator, sc: dict[str, float], base: dict) -> Effect:
    """One effect of ``kind`` with random magnitude and shape relative to the scales."""
    mag = rng.uniform(0.08, 0.2) * sc["force"]
    p = _draw_friction(kind, rng.uniform, mag, sc["stroke"], sc["speed"])
    return make_effect(kind).with_params(p or _draw_other(kind, rng, sc, base, mag))


def _draw_other(
    kind: str, rng: np.random.Generator, sc: dict[str, float], base: dict, mag: float
) -> dict[str, float]:
    """Parameters of an element other than friction or hysteresis (:func:`draw_effect`;
    empty for a kind without a draw rule, which keeps its defaults)."""
    F, X, V, W = sc["force"], sc["stroke"], sc["speed"], sc["frequency"]
    c = float(base.get("c", F / max(V, 1e-9)))
    u = rng.uniform
    p: dict[str, float] = {}
    if kind == "cubic_stiffness":
        p = {"k3": float(rng.choice([-1.0, 1.0])) * u(0.1, 0.25) * F / X**3}
    elif kind == "progressive_stiffness":
        x0 = u(0.2, 0.5) * X
        p = {"x0": x0, "k_p": u(0.15, 0.3) * F / (X - x0) ** 2}
    elif kind == "bump_stop" or kind == "rebound_stop":
        side = sc[kind.removesuffix("_stop")]
        gap = u(0.5, 0.8) * side
        p = {"gap": gap, "k_stop": u(0.3, 0.6) * F / max(side - gap, 1e-12)}
    elif kind == "digressive_damping":
        p = {"c_low": u(1.0, 2.5) * c, "v_knee": u(0.1, 0.3) * V}
    elif kind == "damper_asymmetry":
        p = {"dc_rebound": float(rng.choice([-1.0, 1.0])) * u(0.3, 0.6) * c}
    elif kind == "maxwell_viscoelastic":
        tau = u(0.3, 1.0) / W
        c_m = u(0.4, 0.8) * c
        p = {"c_m": c_m, "k_m": c_m / tau}
    elif kind == "gas_spring":
        p = {"f_0": mag, "k_gas": u(0.1, 0.3) * F / X}
    elif kind == "force_offset":
        p = {"offset": float(rng.choice([-1.0, 1.0])) * mag}
    elif kind == "sensor_lag":
        p = {"tau": u(0.3, 1.0) / W}
    elif kind == "sensor_gain":
        p = {"gain": 1.0 + float(rng.choice([-1.0, 1.0])) * u(0.05, 0.15)}
    elif kind == "sensor_offset":
        # in the unit of the channel it sits on (equal to `mag` for a force channel)
        p = {"offset": float(rng.choice([-1.0, 1.0])) * mag * sc.get("channel", F) / F}
    return p


def truth_pool(family: str) -> list[str]:
    """Effect kinds concealed in ``family``'s cases: its candidates, less those its
    standard baseline already holds (a gas force is not missing physics)."""
    model = make_component(family)
    held = baseline_families(baseline_model(describe_rig(family, [])))
    return [
        k
        for k in model.candidate_effects
        if k not in EXCLUDED.get(family, ()) and family_of(k) not in held
    ]


def _baseline_truth(
    family: str, rng: np.random.Generator, sc: dict[str, float], base: dict, rec: Recording
) -> list[Effect]:
    """The standard baseline's elements with random values: every case carries them (a
    gas damper's gas force, a zero offset, a slowly drifting zero) as real rigs do.
    Sensor elements are sized by the amplitude of the channel they sit on."""
    model = make_component(family)
    sim = model.simulate(model.theta_from(base), rec)
    t_end = float(rec.time[-1])
    out = []
    for e in baseline_model(describe_rig(family, [])).effects:
        if e.spec.role == "sensor":
            y = np.asarray(sim[e.location or model.output_channels[0]], float)
            amp = float(np.percentile(np.abs(y - np.median(y)), 98))
        else:
            amp = sc["force"]
        if e.kind == DRIFT:
            # drifts by 0-2 % of the channel's range over the recording
            out.append(e.with_params({"rate": amp * float(rng.uniform(-0.02, 0.02)) / t_end}))
        else:
            drawn = draw_effect(e.kind, rng, {**sc, "channel": amp}, base)
            out.append(e.with_params(drawn.params))
    return out


#: physics outside the effect library, per family: closed-form forces added to the
#: simulated force (component on a dyno or guide), or a sensor that clips the body
#: acceleration / a deflection transducer with a quadratic calibration error (quarter
#: car); the diagnosis cannot name them and must say so
OUTSIDE_KINDS: dict[str, tuple[str, ...]] = {
    "damper": ("cubic_damping", "velocity_dead_zone"),
    "mr_damper": ("cubic_damping", "velocity_dead_zone"),
    "friction_guide": ("cogging", "cubic_damping"),
    "quarter_car_rig": ("sensor_clipping", "transducer_nonlinearity"),
}
#: most draws of a case's effects (:func:`make_case`: a truth that cannot be simulated,
#: or one with an effect no recorded channel shows, is drawn again)
MAX_DRAWS = 5
#: a case's noise RMS as a fraction of each recorded channel's standard deviation (low,
#: high), drawn uniformly per case
NOISE_FRACTION = (0.01, 0.04)
#: noise of the no-effect controls, by seed: white, coloured (AR(1), correlation time
#: about 10 samples) and white plus a slow, curved zero drift
CONTROL_NOISE = ("white", "coloured", "drift")


def _outside(
    kind: str, rng: np.random.Generator, sc: dict[str, float], rec: Recording
) -> tuple[dict[str, float], np.ndarray | float]:
    """Parameters and the added force [N] of an out-of-library element (force families;
    zero for the quarter car's sensor faults, which act on the recorded channels)."""
    from suspenv.diagnosis.component.motion import motion

    x, v = motion(rec)
    F, X, V = sc["force"], sc["stroke"], sc["speed"]
    if kind == "cubic_damping":
        c3 = float(rng.uniform(0.15, 0.3)) * F / V**3
        return {"c3": c3}, c3 * v**3
    if kind == "velocity_dead_zone":
        # the damping force is missing below v_dz (a valve that opens late)
        v_dz = float(rng.uniform(0.1, 0.2)) * V
        c = F / max(V, 1e-9)
        return {"v_dz": v_dz, "c": c}, -c * v * (np.abs(v) < v_dz)
    if kind == "cogging":
        amp = float(rng.uniform(0.1, 0.25)) * F
        pitch = float(rng.uniform(0.1, 0.25)) * X
        return {"amplitude": amp, "pitch": pitch}, amp * np.sin(2 * np.pi * x / pitch)
    if kind == "sensor_clipping":
        # the accelerometer's range ends at 60-80 % of the largest body acceleration
        return {"fraction_of_peak": float(rng.uniform(0.6, 0.8))}, 0.0
    if kind == "transducer_nonlinearity":
        # x_rec = x + q x |x| / X: 8-15 % error at the stroke amplitude
        return {"q": float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.08, 0.15))}, 0.0
    raise ValidationError(f"unknown out-of-library kind {kind!r}")  # pragma: no cover


#: the blind user's conditions a case may carry (:func:`make_case` ``condition``; what
#: the recording does not say): the quarter car's masses other than the defaults the
#: engine assumes; the output recorded with the other sign (a load cell read
#: tension-positive, a deflection transducer rebound-positive); a force a recorded
#: input does not explain (a valve or coil switched by a signal the recording lacks;
#: dyno and guide families)
CONDITIONS = ("masses_undeclared", "sign_reversed", "input_missing")


def condition_families(condition: str) -> tuple[str, ...]:
    """The families a blind user's ``condition`` (:data:`CONDITIONS`) applies to."""
    return {
        "masses_undeclared": ("quarter_car_rig",),
        "sign_reversed": tuple(BASE_DRAWS),
        "input_missing": RECORDED_MOTION_FAMILIES,
    }.get(condition, ())


def draw_condition(condition: str, family: str, seed: int) -> dict[str, Any]:
    """Seeded values of ``condition`` (:data:`CONDITIONS`), by a generator of its own so
    that every other draw of the case is unchanged."""
    rng = np.random.default_rng([seed, 23, sum(map(ord, family))])
    if family not in condition_families(condition):
        raise ValidationError(
            f"condition must be one of {CONDITIONS} and apply to the family (masses: "
            f"quarter_car_rig; input_missing: {RECORDED_MOTION_FAMILIES}), but got "
            f"({condition!r}, {family!r})"
        )
    if condition == "masses_undeclared":
        # body 0.6-0.85 or 1.2-1.5 times, wheel 0.7-1.5 times the 300 / 40 kg defaults
        body = rng.uniform(0.6, 0.85) if rng.random() < 0.5 else rng.uniform(1.2, 1.5)
        return {"kind": condition, "m_s": 300.0 * body, "m_u": 40.0 * rng.uniform(0.7, 1.5)}
    if condition == "sign_reversed":
        return {"kind": condition}
    # input_missing: extra damping 30-60 % of the base level, switched on and off 4-10 times
    return {
        "kind": condition,
        "share": float(rng.uniform(0.3, 0.6)),
        "switches": np.sort(rng.uniform(0.0, 1.0, int(rng.integers(4, 11)))).tolist(),
    }


def _apply_condition(cond: dict[str, Any] | None, clean: dict[str, Any]) -> None:
    """Apply a drawn condition that acts on the recorded output to the noise-free
    outputs ``clean`` in place (masses act through the truth model's options, an
    unrecorded input through :func:`_noise_free`)."""
    out = "suspension_deflection" if "suspension_deflection" in clean else "force"
    if cond is not None and cond["kind"] == "sign_reversed":
        clean[out] = -np.asarray(clean[out], float)


def _switched_force(cond: dict[str, Any], sc: dict[str, float], rec: Recording) -> np.ndarray:
    """The force [N] of an ``input_missing`` condition: damping ``c v`` with
    ``c = share * force scale / speed scale``, on between odd and even switch times
    (fractions of the recording's span), off elsewhere; v [m/s] the exact velocity."""
    from suspenv.diagnosis.component.motion import motion

    _, v = motion(rec)
    t = (rec.time - rec.time[0]) / max(float(rec.time[-1] - rec.time[0]), 1e-12)
    on = np.searchsorted(np.asarray(cond["switches"]), t) % 2 == 1
    c = cond["share"] * sc["force"] / max(sc["speed"], 1e-12)
    return np.asarray(c * v * on)


def _hidden(
    model: Any,
    standard: list[Effect],
    effects: list[Effect],
    clean: dict[str, np.ndarray],
    simulate: Callable[..., dict[str, np.ndarray]],
) -> bool:
    """Whether one of the drawn ``effects`` changes no recorded channel of the noise-free
    outputs ``clean`` by the largest noise a case may carry (an RMS of
    ``NOISE_FRACTION[1]`` times the channel's standard deviation): a stop beyond the
    travel the other effect leaves is a control with a label, not a concealed effect.
    ``simulate(model, drawn=...)`` gives the outputs without the effect; one whose removal
    cannot be simulated holds the truth together and is shown."""
    for i in range(len(effects)):
        rest = effects[:i] + effects[i + 1 :]
        try:
            other = simulate(model.with_effects(standard + rest), drawn=rest)
        except EvaluationError:
            continue
        shift = {ch: np.asarray(clean[ch], float) - other[ch] for ch in model.output_channels}
        if all(
            np.sqrt(np.mean(d**2)) < NOISE_FRACTION[1] * np.std(clean[ch])
            for ch, d in shift.items()
        ):
            return True
    return False


def _noise_free(
    truth_model: Any,
    base: dict[str, float],
    rec: Recording,
    drawn: list[Effect],
    cond: dict[str, Any] | None,
    sc: dict[str, float],
) -> dict[str, np.ndarray]:
    """Noise-free outputs of ``truth_model`` (base values ``base``). Under
    ``input_missing`` the unrecorded switched force (:func:`_switched_force`) is a force
    the load cell measures: it adds to the modelled force before the ``drawn`` sensor
    effects (the last of the truth model's effects, applied here in its order by their
    own laws). The baseline's sensor elements (zero offset and drift) only shift the
    channel, so the force adds after them as well as before."""
    if cond is None or cond["kind"] != "input_missing":
        return truth_model.simulate(truth_model.theta_from(base), rec)
    sensors = [e for e in drawn if e.spec.role == "sensor"]
    keep = [e for e in truth_model.effects if all(e is not s for s in sensors)]
    pre = truth_model.with_effects(keep)
    clean = pre.simulate(pre.theta_from(base), rec)
    y = np.asarray(clean["force"], float) + _switched_force(cond, sc, rec)
    for e in sensors:
        y = e.sensor(y, rec.time)
    clean["force"] = y
    return clean


#: dyno and guide families whose motion channels are, in half of the cases, recorded as
#: rigs record them (:func:`_recorded_motion`)
RECORDED_MOTION_FAMILIES = ("damper", "mr_damper", "friction_guide")


def _recorded_motion(
    seed: int, family: str, rec: Recording, channels: tuple[str, ...]
) -> tuple[dict[str, np.ndarray], dict[str, Any] | None]:
    """The motion channels as a rig records them, in half of the cases (by a generator of
    its own, so that every other draw of the case is unchanged): the displacement with
    transducer noise (0.05-0.2 % of its amplitude) and the velocity (and a guide's
    acceleration) from a Savitzky-Golay derivative of it (order 2, 15-31 samples), as a
    rig's software makes them. The component felt the exact motion. Returns (inputs,
    description or None)."""
    from scipy.signal import savgol_filter

    inputs = dict(rec.inputs)
    rng = np.random.default_rng([seed, 11, sum(map(ord, family))])
    if family not in RECORDED_MOTION_FAMILIES or rng.random() < 0.5:
        return inputs, None
    xk, vk, *rest = channels
    x = np.asarray(inputs[xk], float)
    dt = float(np.median(np.diff(rec.time)))
    amp = float(np.percentile(np.abs(x - np.median(x)), 98))
    share = float(rng.uniform(5e-4, 2e-3))
    window = int(rng.choice([15, 21, 31]))
    xm = x + share * amp * rng.standard_normal(x.size)
    inputs[xk] = xm
    inputs[vk] = savgol_filter(xm, window, 2, deriv=1, delta=dt)
    for ak in rest:
        inputs[ak] = savgol_filter(xm, window, 2, deriv=2, delta=dt)
    return inputs, {"noise_share": share, "savgol_window": window, "order": 2}


def _noise(
    kind: str, rng: np.random.Generator, y: np.ndarray, t: np.ndarray, frac: float
) -> np.ndarray:
    """Measurement noise of RMS ``frac * std(y)``: white, coloured or white plus drift."""
    sd = frac * float(np.std(y))
    if kind == "coloured":
        from scipy.signal import lfilter

        e = lfilter([1.0], [1.0, -0.9], rng.normal(0.0, 1.0, y.size))
        return np.asarray(e * sd / np.std(e))
    e = rng.normal(0.0, sd, y.size)
    if kind == "drift":
        span = float(t[-1] - t[0]) or 1.0
        phase = float(rng.uniform(0, 2 * np.pi))
        e = e + 2.0 * sd * np.sin(2 * np.pi * (t - t[0]) / (3.0 * span) + phase)
    return e


def make_case(
    family: str,
    seed: int,
    n_effects: int,
    outside: bool = False,
    options: dict[str, Any] | None = None,
    condition: str | None = None,
) -> Case:
    """A concealed case: ``n_effects`` in {0, 1, 2} drawn from the family's pool, or with
    ``outside`` one element from outside the library (:data:`OUTSIDE_KINDS`). Controls
    (no effect) get the noise :data:`CONTROL_NOISE` ``[seed % 3]``. ``options`` are the
    truth model's options where they differ from the family's defaults (e.g. the
    quarter car's masses ``{"m_s": 250.0}``), which the recording does not declare.
    ``condition`` adds one of the blind user's :data:`CONDITIONS` (:func:`draw_condition`;
    the random draws of the case are those without it)."""
    cond = draw_condition(condition, family, seed) if condition else None
    if cond is not None and cond["kind"] == "masses_undeclared":
        options = {**(options or {}), "m_s": cond["m_s"], "m_u": cond["m_u"]}
    salt = 7 if outside else n_effects
    rng = np.random.default_rng([seed, salt, sum(map(ord, family))])
    model = make_component(family, **(options or {}))
    rec = model.example_recording(
        seed=int(rng.integers(1 << 30)), **CASE_RECORDING_OPTIONS.get(family, {})
    )
    base = {k: float(rng.uniform(*b)) for k, b in BASE_DRAWS[family].items()}
    sc = _scales(model, base, rec)
    pool = truth_pool(family)
    n_drawn = 0 if outside else n_effects
    simulate = partial(_noise_free, base=base, rec=rec, cond=cond, sc=sc)
    # a draw whose truth cannot be simulated (a softening spring driven past its peak
    # force: the suspension collapses), or with an effect the recording does not show, is
    # no case: the effects are drawn again
    for attempt in range(MAX_DRAWS):
        kinds = list(rng.choice(pool, size=n_drawn, replace=False)) if n_drawn else []
        # two effects of one signature family would be one finding; redraw the second
        while n_drawn == 2 and family_of(kinds[0]) == family_of(kinds[1]):
            kinds[1] = str(rng.choice(pool))
        effects = [draw_effect(str(k), rng, sc, base) for k in kinds]
        # a sensor error sits on one of the recorded channels (the quarter car has two)
        if len(model.output_channels) > 1:
            effects = [
                replace(e, location=str(rng.choice(model.output_channels)))
                if e.spec.role == "sensor"
                else e
                for e in effects
            ]
        # the family's own element constants (e.g. the quarter car's friction width)
        defaults = model.effect_defaults
        effects = [e.with_params(defaults.get(e.kind, {})) for e in effects]
        standard = _baseline_truth(family, rng, sc, base, rec)
        try:
            clean = simulate(model.with_effects(standard + effects), drawn=effects)
        except EvaluationError:
            if attempt == MAX_DRAWS - 1:
                raise
            continue
        if not _hidden(model, standard, effects, clean, simulate):
            break
        if attempt == MAX_DRAWS - 1:
            raise EvaluationError(f"{family} seed {seed}: every draw hides an effect")
    effect_dicts = [e.to_dict() for e in effects]
    if outside:
        kind = str(rng.choice(OUTSIDE_KINDS[family]))
        params, added = _outside(kind, rng, sc, rec)
        if kind == "sensor_clipping":
            acc = np.asarray(clean["body_acceleration"], float)
            limit = params["fraction_of_peak"] * float(np.max(np.abs(acc)))
            params["limit"] = limit
            clean["body_acceleration"] = np.clip(acc, -limit, limit)
        elif kind == "transducer_nonlinearity":
            x = np.asarray(clean["suspension_deflection"], float)
            clean["suspension_deflection"] = x + params["q"] * x * np.abs(x) / sc["stroke"]
        else:
            clean["force"] = np.asarray(clean["force"], float) + added
        effect_dicts = [{"kind": kind, "outside": True, "params": params}]
    _apply_condition(cond, clean)
    frac = float(rng.uniform(*NOISE_FRACTION))
    noise_kind = CONTROL_NOISE[seed % 3] if (n_drawn == 0 and not outside) else "white"
    measured = {}
    for channel in model.output_channels:
        y = np.asarray(clean[channel], float)
        measured[channel] = y + _noise(noise_kind, rng, y, rec.time, frac)
    noise_rms = frac * float(np.std(clean[model.output_channels[0]]))
    case_id = f"{family}-{'out' if outside else n_effects}-{seed}"
    case_id += f"-{cond['kind']}" if cond else ""
    recorded, motion_record = _recorded_motion(seed, family, rec, model.input_channels)
    out = Recording(
        case_id,
        rec.test,
        rec.time,
        recorded,
        measured,
        dict(rec.units),
        {"source": "synthetic blind case", "sampling": rec.meta.get("sampling", {})},
    )
    truth = Truth(
        case_id,
        family,
        seed,
        base,
        effect_dicts,
        noise_rms,
        frac,
        [e.to_dict() for e in standard],
        noise_kind,
        outside,
        motion_record,
        cond,
    )
    return Case(out, truth)


def write_case(case: Case, case_dir: Path | str, truth_dir: Path | str) -> tuple[Path, Path]:
    """Write the case recording and, in a separate folder, its truth JSON."""
    rec_path = save_recording(case.recording, Path(case_dir) / f"{case.truth.case_id}.npz")
    truth_path = Path(truth_dir) / f"{case.truth.case_id}.json"
    truth_path.parent.mkdir(parents=True, exist_ok=True)
    truth_path.write_text(json.dumps(case.truth.to_dict(), indent=2) + "\n")
    return rec_path, truth_path


#: the field-dependent MR damper of :func:`mr_field_case` (Spencer 1997 form, SI; the
#: field parameters per ampere)
MR_FIELD_TRUTH: dict[str, float] = {
    "c": 800.0,
    "k": 500.0,
    "f_0": 5.0,
    "c_field": 1500.0,
    "f_y": 40.0,
    "f_field": 300.0,
    "x_y": 1.5e-3,
    "shape": 0.5,
}


def mr_field_case(seed: int, duration: float = 60.0, dt: float = 0.01, noise: float = 0.01) -> Case:
    """An MR damper under random (band-limited white-noise) displacement whose coil
    current switches between 0 and 1 A at random times (dwells of 2-6 s), recorded with
    the ``coil_current`` channel [A] and white force noise of ``noise`` x the force's
    standard deviation. The truth is :data:`MR_FIELD_TRUTH` in
    :class:`~suspenv.models.components.mr_damper.MRFieldDamperModel`.

    The displacement is a sum of 40 sines of random phase, 0.3-3 Hz, scaled to 8 mm
    RMS; the velocity is its exact derivative."""
    rng = np.random.default_rng([seed, 39])
    t = np.arange(0.0, duration, dt)
    freqs = np.linspace(0.3, 3.0, 40)
    phases = rng.uniform(0.0, 2 * np.pi, freqs.size)
    arg = 2 * np.pi * freqs[:, None] * t[None, :] + phases[:, None]
    x, v = np.sum(np.sin(arg), axis=0), np.sum(2 * np.pi * freqs[:, None] * np.cos(arg), axis=0)
    scale = 0.008 / float(np.std(x))
    x, v = x * scale, v * scale
    switches = np.cumsum(rng.uniform(2.0, 6.0, int(duration / 2.0) + 1))
    level = rng.integers(0, 2)
    current = ((np.searchsorted(switches, t) + level) % 2).astype(float)
    units = {"displacement": "m", "velocity": "m/s", "coil_current": "A", "force": "N"}
    inputs = {"displacement": x, "velocity": v, "coil_current": current}
    rec = Recording(f"mr-field-{seed}", "mr_random", t, inputs, {}, units)
    model = make_component("mr_damper", field="coil_current")
    clean = model.simulate(model.theta_from(MR_FIELD_TRUTH), rec)["force"]
    sd = noise * float(np.std(clean))
    measured = clean + rng.normal(0.0, sd, t.size)
    meta = {"source": "synthetic MR damper, switching coil current", "sampling": {"dt_s": dt}}
    out = Recording(rec.name, rec.test, t, inputs, {"force": measured}, units, meta)
    truth = Truth(rec.name, "mr_damper", seed, dict(MR_FIELD_TRUTH), [], sd, noise)
    return Case(out, truth)
