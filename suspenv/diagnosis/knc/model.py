"""The McPherson axle on the K&C rig behind the component-model API of the diagnosis engine.

Family ``"knc_axle"``. ``simulate(theta, rec)`` replays the loop of a K&C recording
(:mod:`suspenv.diagnosis.knc.recording`) on the compliant axle
(:mod:`suspenv.models.mcpherson`, :func:`suspenv.rigs.knc.run_tests`) and returns the
recorded channels (SI, ISO 8855, lateral outboard positive). ``theta`` may be one
vector ``(p,)`` or a batch ``(B, p)``; rows that share the path-dependent effect
values are solved as one batch.

Fitted base parameters (:data:`FIT_PARAMETERS`): a small subset of the 49 that K&C
loops identify well and that move different channels, so a fit is quick and well
conditioned (the others stay at the start design, by default the reference vehicle):

* ``static_toe`` / ``static_camber``: toe and camber at the design position (values);
* ``tie_rod_inner_z``: the toe-vs-travel slope (bump steer);
* ``lca_front_bush_z`` / ``lca_rear_bush_z``: lower-arm inclination in side and front
  view: camber gain, lateral and fore-aft contact-patch motion;
* ``strut_top_y``: strut inclination: camber gain, lateral motion;
* ``top_mount_kz``: compliance in series with the spring: ride rate;
* ``arb_torsion``: the bar: roll (opposite travel) and single-wheel rate.

Effects (parameters in the spec's units; the engine names them with the effects
library's words, e.g. "rubber bushing hysteresis (Dahl) in the lower-arm bushes and
top mount"):

* ``dahl_hysteresis``: Dahl elements in both lower-arm bushes and the top mount
  (candidates ``dahl_hysteresis:lower_arm`` / ``dahl_hysteresis:top_mount``: only
  there; the refits compare the locations); ``f_c`` [N] saturation force, moments
  ``f_c * MOMENT_ARM`` [N*m]; initial stiffness equal to each bushing's own stiffness
  (``hysteresis_sigma_ratio = 1``);
* ``coulomb_friction``: rod/tube friction in the strut, ``f_c`` [N];
* ``cubic_stiffness``: progressive bushings (all four), ``ratio`` [-] = cubic force
  over linear force at 1 mm deflection;
* ``lr_asymmetry``: right-minus-left differences (the sides sit at -d/2, +d/2 about
  the fitted value) of static toe and camber [deg], tie-rod inner z and lower ball
  joint z [mm], and top-mount kz (relative);
* ``sensor_gain`` / ``sensor_offset``: calibration gain [-] / zero offset [N] of both
  wheel-load cells (``tyre_fz``).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.core.space import Parameter
from suspenv.diagnosis.knc.recording import (
    CHANNELS,
    SIDES,
    channels_of,
    output_names,
    rig_test,
)
from suspenv.models.effects import make_effect
from suspenv.models.mcpherson import AxleEffects, build_axle, design_space
from suspenv.models.mcpherson.params import PARAMETER_NAMES
from suspenv.recordings import Recording
from suspenv.rigs.knc import FORCE_TESTS, TESTS, run_tests

FIT_PARAMETERS = (
    "static_toe",
    "static_camber",
    "tie_rod_inner_z",
    "lca_front_bush_z",
    "lca_rear_bush_z",
    "strut_top_y",
    "top_mount_kz",
    "arb_torsion",
)
#: moment saturation of the bushing hysteresis per newton of force saturation [m]
MOMENT_ARM = 0.05
#: hysteresis candidates (effect name) -> bushings with Dahl elements, and their words
HYSTERESIS_VARIANTS = {
    "dahl_hysteresis": (("lca_front", "lca_rear", "top_mount"), "lower-arm bushes and top mount"),
    "dahl_hysteresis:lower_arm": (("lca_front", "lca_rear"), "lower-arm bushes"),
    "dahl_hysteresis:top_mount": (("top_mount",), "top mount"),
}
CUBIC_BUSHINGS = ("lca_front", "lca_rear", "arb_bush", "top_mount")
#: lr_asymmetry parameter -> (design parameter, relative?)
ASYMMETRY_TARGETS = {
    "d_static_toe": ("static_toe", False),
    "d_static_camber": ("static_camber", False),
    "d_tie_rod_inner_z": ("tie_rod_inner_z", False),
    "d_lower_ball_joint_z": ("lower_ball_joint_z", False),
    "d_top_mount_kz": ("top_mount_kz", True),
}

#: free parameters of every candidate effect (spec units)
EFFECT_PARAMETERS: dict[str, tuple[Parameter, ...]] = {
    "dahl_hysteresis": (
        Parameter("f_c", 1.0, 1000.0, "N", default=40.0, description="saturation force"),
    ),
    "coulomb_friction": (
        Parameter("f_c", 1.0, 2000.0, "N", default=40.0, description="strut friction level"),
    ),
    "cubic_stiffness": (
        Parameter("ratio", 1e-3, 3.0, "", default=0.05, description="cubic/linear at 1 mm"),
    ),
    "lr_asymmetry": (
        Parameter("d_static_toe", -0.5, 0.5, "deg", default=0.0),
        Parameter("d_static_camber", -0.5, 0.5, "deg", default=0.0),
        Parameter("d_tie_rod_inner_z", -6.0, 6.0, "mm", default=0.0),
        Parameter("d_lower_ball_joint_z", -6.0, 6.0, "mm", default=0.0),
        Parameter("d_top_mount_kz", -0.5, 0.5, "", default=0.0),
    ),
    "sensor_gain": (Parameter("gain", 0.8, 1.25, "", default=1.0, description="gain factor"),),
    "sensor_offset": (
        Parameter("offset", -500.0, 500.0, "N", default=0.0, description="zero offset"),
    ),
}
#: where each effect acts, in engineering words
EFFECT_LOCATIONS = {
    "dahl_hysteresis": HYSTERESIS_VARIANTS["dahl_hysteresis"][1],
    "coulomb_friction": "strut",
    "cubic_stiffness": "bushings",
    "lr_asymmetry": "",
    "sensor_gain": "wheel-load cells",
    "sensor_offset": "wheel-load cells",
}


@dataclass(frozen=True)
class KncEffect:
    """One effect of the axle model: kind (an effects-library kind), name, values."""

    kind: str
    name: str = ""
    params: dict[str, float] = field(default_factory=dict)
    location: str = ""

    def __post_init__(self) -> None:
        if self.kind not in EFFECT_PARAMETERS:
            raise ValidationError(
                f"K&C effect kind must be one of {sorted(EFFECT_PARAMETERS)}, but got {self.kind!r}"
            )
        if not self.name:
            object.__setattr__(self, "name", self.kind)
        if not self.location:
            object.__setattr__(self, "location", EFFECT_LOCATIONS[self.kind])
        full = {p.name: float(p.default) for p in EFFECT_PARAMETERS[self.kind]}
        unknown = sorted(set(self.params) - set(full))
        if unknown:
            raise ValidationError(
                f"K&C effect {self.kind}: unknown parameter(s) {unknown}; allowed {sorted(full)}"
            )
        full.update(self.params)
        object.__setattr__(self, "params", full)

    @property
    def spec_parameters(self) -> tuple[Parameter, ...]:
        return EFFECT_PARAMETERS[self.kind]

    @property
    def words(self) -> str:
        """Engineering words from the effects library, with the location."""
        return make_effect(self.kind, location=self.location).words

    def with_params(self, values: Mapping[str, Any]) -> KncEffect:
        return KncEffect(self.kind, self.name, {**self.params, **dict(values)}, self.location)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "name": self.name,
            "location": self.location,
            "params": {k: float(np.asarray(v).ravel()[0]) for k, v in self.params.items()},
        }


def base_kind(candidate: str) -> str:
    """Effects-library kind of a candidate name (``"dahl_hysteresis:top_mount"`` -> its kind)."""
    return candidate.split(":", 1)[0]


def make_candidate(candidate: str, **params: float) -> KncEffect:
    """The effect of a candidate name: a kind, or a kind with a location variant."""
    kind = base_kind(candidate)
    if candidate in HYSTERESIS_VARIANTS:
        return KncEffect(kind, candidate, dict(params), HYSTERESIS_VARIANTS[candidate][1])
    if candidate != kind:
        raise ValidationError(
            f"candidate must be a K&C effect kind or one of {sorted(HYSTERESIS_VARIANTS)}, "
            f"but got {candidate!r}"
        )
    return KncEffect(kind, kind, dict(params))


def axle_effects(effects: Sequence[KncEffect]) -> AxleEffects:
    """The solver's :class:`AxleEffects` for the force effects in ``effects`` (scalars)."""
    kw: dict[str, Any] = {}
    for e in effects:
        if e.kind == "dahl_hysteresis":
            fc = float(e.params["f_c"])
            kw.update(
                hysteresis_bushings=HYSTERESIS_VARIANTS.get(e.name, HYSTERESIS_VARIANTS[e.kind])[0],
                hysteresis_sigma_ratio=1.0,
                hysteresis_fc_force=fc,
                hysteresis_fc_moment=fc * MOMENT_ARM,
            )
        elif e.kind == "coulomb_friction":
            kw["strut_friction"] = float(e.params["f_c"])
        elif e.kind == "cubic_stiffness":
            kw.update(cubic_bushings=CUBIC_BUSHINGS, cubic_ratio=float(e.params["ratio"]))
    return AxleEffects(**kw)


def apply_asymmetry(
    X: np.ndarray, params: Mapping[str, np.ndarray | float]
) -> tuple[np.ndarray, np.ndarray]:
    """Left and right designs (B, 49) about ``X`` with right-minus-left differences."""
    left, right = X.copy(), X.copy()
    for pname, (dname, relative) in ASYMMETRY_TARGETS.items():
        j = PARAMETER_NAMES.index(dname)
        d = np.asarray(params[pname], float) * np.ones(X.shape[0])
        half = 0.5 * d * (X[:, j] if relative else 1.0)
        left[:, j] -= half
        right[:, j] += half
    return left, right


class KncAxleModel:
    """McPherson axle + K&C rig with the component-model interface (family ``knc_axle``).

    Args:
        effects: :class:`KncEffect` list (the model is "base + effects").
        design: start design (49,) in the spec's units (default: the reference vehicle);
            the parameters not fitted stay at these values.
        fit_parameters: names of the fitted base parameters (default :data:`FIT_PARAMETERS`).
        frozen: values of the fitted base parameters to hold fixed; the model's
            ``theta`` then holds only the effects' parameters (used for a quick refit).
        tests: rig tests simulated together per call (cached by ``theta``); the travel
            and the compliance tests among them form two batches.
    """

    family: ClassVar[str] = "knc_axle"
    description: ClassVar[str] = "McPherson front axle on the K&C rig (quasi-static)"
    candidate_effects: ClassVar[tuple[str, ...]] = (
        "dahl_hysteresis",
        "dahl_hysteresis:lower_arm",
        "dahl_hysteresis:top_mount",
        "coulomb_friction",
        "cubic_stiffness",
        "lr_asymmetry",
        "sensor_gain",
        "sensor_offset",
    )
    location: ClassVar[str] = "axle"
    output_channels: ClassVar[tuple[str, ...]] = output_names()
    channel_units: ClassVar[dict[str, str]] = {
        f"{c}_{s}": u for c, (_, u, _) in CHANNELS.items() for s in SIDES
    }

    def __init__(
        self,
        effects: Sequence[KncEffect] = (),
        design: np.ndarray | None = None,
        fit_parameters: Sequence[str] = FIT_PARAMETERS,
        frozen: Mapping[str, float] | None = None,
        tests: Sequence[str] = TESTS,
    ):
        self.effects = tuple(effects)
        space = design_space()
        self.design = space.reference() if design is None else np.asarray(design, float).copy()
        if self.design.shape != (len(PARAMETER_NAMES),):
            raise ValidationError(
                f"design must have {len(PARAMETER_NAMES)} values, but got {self.design.shape}"
            )
        bad = [p for p in fit_parameters if p not in PARAMETER_NAMES]
        if bad:
            raise ValidationError(f"fit_parameters must be design parameters, but got {bad}")
        kinds = [e.kind for e in self.effects]
        dup = sorted({k for k in kinds if kinds.count(k) > 1})
        if dup:
            raise ValidationError(f"each effect kind may appear once, but got repeats {dup}")
        self.fit_parameters = tuple(fit_parameters)
        self.frozen = None if frozen is None else {k: float(frozen[k]) for k in fit_parameters}
        self.tests = tuple(tests)
        self._params = {p.name: p for p in space.parameters}
        self._cache: OrderedDict[tuple, dict] = OrderedDict()
        self._rows: OrderedDict[tuple, tuple] = OrderedDict()
        self.options = {
            "design": self.design,
            "fit_parameters": self.fit_parameters,
            "frozen": self.frozen,
            "tests": self.tests,
        }
        self.stats = {"simulations": 0, "rows": 0}

    # ------------------------------------------------------------------ names and bounds
    @property
    def base_names(self) -> tuple[str, ...]:
        return () if self.frozen is not None else self.fit_parameters

    @property
    def parameter_names(self) -> tuple[str, ...]:
        names = list(self.base_names)
        for e in self.effects:
            names += [f"{e.name}.{p.name}" for p in e.spec_parameters]
        return tuple(names)

    @property
    def parameter_units(self) -> tuple[str, ...]:
        units = [self._params[n].unit for n in self.base_names]
        for e in self.effects:
            units += [p.unit for p in e.spec_parameters]
        return tuple(units)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = [self._params[n].low for n in self.base_names]
        hi = [self._params[n].high for n in self.base_names]
        for e in self.effects:
            lo += [p.low for p in e.spec_parameters]
            hi += [p.high for p in e.spec_parameters]
        return np.array(lo, float), np.array(hi, float)

    def base_values(self) -> dict[str, float]:
        """Values of the fitted base parameters at the start design (or the frozen ones)."""
        if self.frozen is not None:
            return dict(self.frozen)
        return {n: float(self.design[PARAMETER_NAMES.index(n)]) for n in self.fit_parameters}

    def initial_guess(self, rec: Recording | None = None) -> np.ndarray:
        vals = [self.base_values()[n] for n in self.base_names]
        for e in self.effects:
            vals += [float(e.params[p.name]) for p in e.spec_parameters]
        lo, hi = self.bounds()
        return np.clip(np.array(vals, float), lo, hi)

    def theta_from(self, base: Mapping[str, float], effects: Sequence[KncEffect]) -> np.ndarray:
        vals = [float(base[n]) for n in self.base_names]
        for e in effects:
            vals += [float(e.params[p.name]) for p in e.spec_parameters]
        return np.array(vals, float)

    def values(self, theta: np.ndarray) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.parameter_names, theta, strict=True)}

    def unpack(self, theta: np.ndarray) -> tuple[dict[str, np.ndarray], list[KncEffect]]:
        """Base values (B,) per fitted parameter and effects with (B,) parameter arrays."""
        th = np.atleast_2d(np.asarray(theta, float))
        p = len(self.parameter_names)
        if th.shape[1] != p or np.ndim(theta) > 2:
            raise ValidationError(
                f"knc_axle: theta must have shape ({p},) or (B, {p}) for parameters "
                f"{self.parameter_names}, but got {np.shape(theta)}"
            )
        if not np.all(np.isfinite(th)):
            raise ValidationError(f"knc_axle: theta must be finite, but got {theta}")
        cols = th.T
        if self.frozen is not None:
            base = {n: np.full(th.shape[0], v) for n, v in self.frozen.items()}
            k = 0
        else:
            base = {n: cols[i] for i, n in enumerate(self.fit_parameters)}
            k = len(self.fit_parameters)
        effects = []
        for e in self.effects:
            names = [q.name for q in e.spec_parameters]
            effects.append(
                KncEffect(e.kind, e.name, {q: cols[k + j] for j, q in enumerate(names)}, e.location)
            )
            k += len(names)
        return base, effects

    # ------------------------------------------------------------------ simulation
    def designs(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Left and right design vectors (B, 49) of ``theta``."""
        base, effects = self.unpack(theta)
        B = next(iter(base.values())).shape[0]
        X = np.tile(self.design, (B, 1))
        for n, v in base.items():
            X[:, PARAMETER_NAMES.index(n)] = v
        asym = [e for e in effects if e.kind == "lr_asymmetry"]
        if asym:
            return apply_asymmetry(X, asym[0].params)
        return X, X.copy()

    def _run(
        self, theta: np.ndarray, amplitude: float, steps: int, tests: tuple[str, ...]
    ) -> dict[str, dict]:
        """Recorded channels of ``tests`` for every row of ``theta`` (cached)."""
        th = np.atleast_2d(np.asarray(theta, float))
        key = (th.tobytes(), th.shape, float(amplitude), int(steps), tests)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        _, effects = self.unpack(th)
        left, right = self.designs(th)
        B = th.shape[0]
        force = [e for e in effects if e.kind in ("dahl_hysteresis", "coulomb_friction")]
        force += [e for e in effects if e.kind == "cubic_stiffness"]
        # rows sharing the solver effects are solved as one batch
        sig = (
            np.stack(
                [
                    np.asarray(e.params[q.name], float) * np.ones(B)
                    for e in force
                    for q in e.spec_parameters
                ],
                axis=1,
            )
            if force
            else np.zeros((B, 0))
        )
        groups: dict[bytes, list[int]] = {}
        for i in range(B):
            groups.setdefault(sig[i].tobytes(), []).append(i)
        nan = {name: np.full((B, 2 * steps + 1), np.nan) for name in output_names()}
        out = {t: {k: v.copy() for k, v in nan.items()} for t in tests}
        messages = [""] * B
        for rows in groups.values():
            eff = axle_effects(
                [e.with_params({k: float(v[rows[0]]) for k, v in e.params.items()}) for e in force]
            )
            keys = [
                (left[i].tobytes(), right[i].tobytes(), repr(eff), amplitude, steps, tests)
                for i in rows
            ]
            todo = [i for i, k in zip(rows, keys, strict=True) if k not in self._rows]
            if todo:
                res = run_tests(  # the tests of one call share their kind (travel or force)
                    build_axle(left[todo], right[todo]),
                    tests,
                    amplitude=amplitude,
                    steps=steps,
                    effects=eff,
                    force_amplitude=amplitude,
                )
                self.stats["simulations"] += 1
                self.stats["rows"] += len(todo)
                for j, i in enumerate(todo):
                    msg = next((r.messages[j] for r in res.values() if not r.ok[j]), "")
                    chans = {t: channels_of(r, j) for t, r in res.items()} if not msg else {}
                    self._rows[keys[rows.index(i)]] = (chans, msg)
                    if len(self._rows) > 64:
                        self._rows.popitem(last=False)
            for i, k in zip(rows, keys, strict=True):
                chans, msg = self._rows[k]
                messages[i] = msg
                for t, ch in chans.items():
                    for name, v in ch.items():
                        out[t][name][i] = v
        for e in effects:
            if e.kind in ("sensor_gain", "sensor_offset"):
                for t in out:
                    for side in SIDES:
                        k = f"tyre_fz_{side}"
                        if e.kind == "sensor_gain":
                            out[t][k] = out[t][k] * np.asarray(e.params["gain"])[:, None]
                        else:
                            out[t][k] = out[t][k] + np.asarray(e.params["offset"])[:, None]
        result = {"channels": out, "messages": messages}
        self._cache[key] = result
        if len(self._cache) > 6:
            self._cache.popitem(last=False)
        return result

    def simulate(self, theta: np.ndarray, rec: Recording) -> dict[str, np.ndarray]:
        """Predicted outputs of recording ``rec``: ``(P,)`` per channel, or ``(B, P)``."""
        test = rig_test(rec)
        amp, steps = float(rec.meta["amplitude"]), int(rec.meta["steps"])
        # travel tests (amplitude in m) and compliance tests (in N) run as two batches
        kind = test in FORCE_TESTS
        same_kind = tuple(t for t in self.tests if (t in FORCE_TESTS) == kind)
        tests = same_kind if test in same_kind else (test,)
        res = self._run(theta, amp, steps, tests)
        chans = res["channels"][test]
        if np.ndim(theta) == 1:
            if res["messages"][0]:
                raise EvaluationError(f"knc_axle: {res['messages'][0]}")
            return {k: v[0] for k, v in chans.items()}
        return {k: v.copy() for k, v in chans.items()}

    # ------------------------------------------------------------------ composition
    def with_effects(self, effects: Sequence[KncEffect]) -> KncAxleModel:
        return KncAxleModel(effects, self.design, self.fit_parameters, self.frozen, self.tests)

    def frozen_at(self, base: Mapping[str, float]) -> KncAxleModel:
        """The same model with the fitted base parameters held at ``base``."""
        return KncAxleModel(self.effects, self.design, self.fit_parameters, base, self.tests)

    def released(self) -> KncAxleModel:
        """The same model with its base parameters free again."""
        return KncAxleModel(self.effects, self.design, self.fit_parameters, None, self.tests)

    def effect_words(self, effect: KncEffect) -> str:
        return effect.words

    def config(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "fit_parameters": list(self.fit_parameters),
            "effects": [e.to_dict() for e in self.effects],
        }

    def __repr__(self) -> str:
        effs = ", ".join(e.kind for e in self.effects)
        return f"KncAxleModel(effects=[{effs}], fit={list(self.base_names)})"
