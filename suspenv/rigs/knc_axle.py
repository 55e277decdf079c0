"""The McPherson axle on the K&C rig behind the component-model API of the diagnosis engine.

Family ``"knc_axle"``. ``simulate(theta, rec)`` replays the loop of a K&C recording
(:mod:`suspenv.measurements.knc`) on the compliant axle
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

Effects: effects-library :class:`~suspenv.models.effects.Effect` objects, the same the
truth generator (:mod:`suspenv.rigs.knc_truth`) and the solver take; candidates
are written ``kind@location`` (:func:`make_candidate`; a kind alone sits at its
default location, :data:`KNC_EFFECTS`, which also holds the fitted parameters with
the K&C bounds). Parameters in the spec's units; the engine names them with the
library's words and the location in words (:func:`effect_words`, e.g. "rubber
bushing hysteresis (Dahl) in the lower-arm bushes and top mount"):

* ``dahl_hysteresis``: Dahl elements in both lower-arm bushes and the top mount
  (candidates ``dahl_hysteresis@lower_arm`` / ``dahl_hysteresis@top_mount``: only
  there; the refits compare the locations); ``f_c`` [N] saturation force, moments
  ``f_c * MOMENT_ARM`` [N*m] (:data:`suspenv.models.mcpherson.MOMENT_ARM`); initial
  stiffness equal to each bushing's own stiffness (``sigma_ratio = 1``);
* ``coulomb_friction@strut``: rod/tube friction in the strut, ``f_c`` [N];
* ``cubic_stiffness@bushings``: progressive bushings (all four), ``ratio`` [-] =
  cubic force over linear force at ``x_ref`` = 1 mm deflection;
* ``lr_asymmetry``: right-minus-left differences (the sides sit at -d/2, +d/2 about
  the fitted value) of static toe and camber [deg], tie-rod inner z and lower ball
  joint z [mm], and top-mount kz (relative): the library's pair kind with the axle's
  host-declared parameters ``d_<design parameter>``;
* ``sensor_gain@tyre_fz`` / ``sensor_offset@tyre_fz``: calibration gain [-] / zero
  offset [N] of both wheel-load cells.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.core.space import DesignSpace, Parameter
from suspenv.measurements import Recording
from suspenv.measurements.knc import (
    CHANNELS,
    DRIVE_UNIT,
    SIDES,
    STEER_TESTS,
    output_names,
    rig_test,
)
from suspenv.models.components.base import FitDefaults
from suspenv.models.effects import Effect, get_kind, make_effect
from suspenv.models.mcpherson import (
    build_axle,
    check_placement,
    design_space,
    location_words,
)
from suspenv.models.mcpherson.params import PARAMETER_NAMES
from suspenv.rigs.knc import FORCE_TESTS, TESTS
from suspenv.rigs.knc_fit import effect_scale, fit_space, rig_run, same_rows
from suspenv.rigs.knc_recording import channels_of

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
#: lr_asymmetry parameter -> (design parameter, relative?)
ASYMMETRY_TARGETS = {
    "d_static_toe": ("static_toe", False),
    "d_static_camber": ("static_camber", False),
    "d_tie_rod_inner_z": ("tie_rod_inner_z", False),
    "d_lower_ball_joint_z": ("lower_ball_joint_z", False),
    "d_top_mount_kz": ("top_mount_kz", True),
}
#: the channel the sensor effects sit on (both wheel-load cells), and its words
SENSOR_CHANNEL = "tyre_fz"
SENSOR_WORDS = "wheel-load cells"


def _narrow(
    kind: str, name: str, low: float, high: float, start: float, unit: str | None = None
) -> Parameter:
    """The effects library's parameter ``name`` of ``kind`` with the K&C fit's bounds and start."""
    p = get_kind(kind).parameter(name)
    return replace(p, low=low, high=high, default=start, unit=p.unit if unit is None else unit)


#: the K&C model's effects: kind -> (location of a candidate written without
#: ``@location``, the fitted parameters). The fitted parameters are the effects
#: library's, with the bounds and start values the K&C loops need; lr_asymmetry's are
#: the axle's own right-minus-left design differences (host-declared ``d_<parameter>``).
#: Every other parameter of an effect stays at its stored value.
KNC_EFFECTS: dict[str, tuple[str, tuple[Parameter, ...]]] = {
    "dahl_hysteresis": (
        "lower_arm_and_top_mount",
        (_narrow("dahl_hysteresis", "f_c", 1.0, 1000.0, 40.0),),
    ),
    "coulomb_friction": ("strut", (_narrow("coulomb_friction", "f_c", 1.0, 2000.0, 40.0),)),
    "cubic_stiffness": ("bushings", (_narrow("cubic_stiffness", "ratio", 1e-3, 3.0, 0.05),)),
    "lr_asymmetry": (
        "",
        (
            Parameter("d_static_toe", -0.5, 0.5, "deg", default=0.0),
            Parameter("d_static_camber", -0.5, 0.5, "deg", default=0.0),
            Parameter("d_tie_rod_inner_z", -6.0, 6.0, "mm", default=0.0),
            Parameter("d_lower_ball_joint_z", -6.0, 6.0, "mm", default=0.0),
            Parameter("d_top_mount_kz", -0.5, 0.5, "", default=0.0),
        ),
    ),
    "sensor_gain": (SENSOR_CHANNEL, (_narrow("sensor_gain", "gain", 0.8, 1.25, 1.0),)),
    "sensor_offset": (
        SENSOR_CHANNEL,
        (_narrow("sensor_offset", "offset", -500.0, 500.0, 0.0, unit="N"),),
    ),
}


def base_kind(candidate: str) -> str:
    """Effects-library kind of a candidate name (``"dahl_hysteresis@top_mount"`` -> its kind)."""
    return candidate.partition("@")[0]


def fitted_parameters(effect: Effect) -> tuple[Parameter, ...]:
    """The parameters of ``effect`` the K&C model fits (bounds, unit, start value)."""
    if effect.kind not in KNC_EFFECTS:
        raise ValidationError(
            f"K&C effect kind must be one of {sorted(KNC_EFFECTS)}, but got {effect.kind!r}"
        )
    return KNC_EFFECTS[effect.kind][1]


def effect_parameters(effect: Effect) -> list[Parameter]:
    """The fitted parameters of ``effect`` named ``<effect>.<parameter>``, positive ranges
    on a log scale (as the shared K&C fit maps them, :mod:`suspenv.rigs.knc_fit`)."""
    return [
        effect_scale(replace(p, name=f"{effect.name}.{p.name}")) for p in fitted_parameters(effect)
    ]


def check_effect(effect: Effect) -> None:
    """Raise :class:`ValidationError` unless the K&C model can carry ``effect`` where it is."""
    if not isinstance(effect, Effect):
        raise ValidationError(
            f"K&C effects must be Effect instances, but got {type(effect).__name__}"
        )
    fitted_parameters(effect)  # a kind the K&C model knows
    role = effect.spec.role
    if role == "force":
        check_placement(effect)
    elif role == "sensor" and effect.location != SENSOR_CHANNEL:
        raise ValidationError(
            f"K&C sensor effect {effect.name!r}: `location == {SENSOR_CHANNEL!r}` (the "
            f"wheel-load cells) must hold, but got {effect.location!r}"
        )
    elif role == "pair":
        if effect.location:
            raise ValidationError(
                f"K&C effect {effect.name!r}: lr_asymmetry acts on the design (no location), "
                f"but got location {effect.location!r}"
            )
        bad = sorted(set(effect.params) - set(ASYMMETRY_TARGETS))
        if bad:
            raise ValidationError(
                f"K&C effect {effect.name!r}: lr_asymmetry parameters must be among "
                f"{sorted(ASYMMETRY_TARGETS)}, but got {bad}"
            )


def make_candidate(candidate: str, **params: float) -> Effect:
    """The effect of a candidate name ``kind`` or ``kind@location`` (``location``: a
    bushing, a group of bushings or ``strut``, see :mod:`suspenv.models.mcpherson.effects`),
    with the K&C start values unless ``params`` gives others.

    A kind alone sits at its default location (:data:`KNC_EFFECTS`: plain
    ``dahl_hysteresis`` in both lower-arm bushes and the top mount). The effect's name
    is the kind at its default location, else the candidate ``kind@location``.
    """
    if ":" in candidate:
        raise ValidationError(f"candidate names are written `kind@location`, but got {candidate!r}")
    kind, _, where = candidate.partition("@")
    if kind not in KNC_EFFECTS:
        raise ValidationError(
            f"candidate kind must be one of {sorted(KNC_EFFECTS)}, but got {kind!r} "
            f"(candidate {candidate!r})"
        )
    default, fitted = KNC_EFFECTS[kind]
    location = where or default
    values: dict[str, float] = {p.name: float(p.default) for p in fitted if p.default is not None}
    values.update(params)
    name = kind if location == default else f"{kind}@{location}"
    effect = make_effect(kind, name=name, location=location, **values)
    check_effect(effect)
    return effect


def effect_words(effect: Effect) -> str:
    """Engineering words of a K&C effect: the library's, with the location in words."""
    if effect.spec.role == "force":
        where = location_words(effect.location)
    elif effect.spec.role == "sensor":
        where = SENSOR_WORDS
    else:
        where = ""
    return f"{effect.spec.words} in the {where}" if where else effect.spec.words


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


def _row_value(v: object, row: int, n: int) -> float:
    """Value of a (scalar or ``(n,)``) effect parameter in batch row ``row``."""
    return float(np.broadcast_to(np.asarray(v, float), (n,))[row])


def _effect_values(force: Sequence[Effect], B: int) -> np.ndarray:
    """The fitted parameter values (B, k) of the solver effects ``force`` per row of a
    batch of ``B`` (a value given once holds for every row); rows with equal values
    share one solver."""
    if not force:
        return np.zeros((B, 0))
    return np.stack(
        [
            np.asarray(e.params[q.name], float) * np.ones(B)
            for e in force
            for q in fitted_parameters(e)
        ],
        axis=1,
    )


def _apply_sensors(effects: Sequence[Effect], out: dict[str, dict[str, np.ndarray]]) -> None:
    """Pass the recorded channels ``out`` {test: {channel: (B, P)}} through the sensor
    effects (each reads its channel on both sides), in place."""
    for e in effects:
        if e.spec.role == "sensor":
            for t in out:
                for side in SIDES:
                    name = f"{e.location}_{side}"
                    out[t][name] = e.sensor(out[t][name])


class KncAxleModel(FitDefaults):
    """McPherson axle + K&C rig with the component-model interface (family ``knc_axle``).

    Args:
        effects: effects-library :class:`~suspenv.models.effects.Effect` list (the model
            is "base + effects"; see :func:`make_candidate` and :func:`check_effect`).
        design: start design (49,) in the spec's units (default: the reference vehicle);
            the parameters not fitted stay at these values.
        fit_parameters: names of the fitted base parameters (default :data:`FIT_PARAMETERS`).
        tests: rig tests simulated together per call (cached by ``theta``); the travel
            and the compliance tests among them form two batches.
    """

    family: ClassVar[str] = "knc_axle"
    description: ClassVar[str] = "McPherson front axle on the K&C rig (quasi-static)"
    candidate_effects: ClassVar[tuple[str, ...]] = (
        "dahl_hysteresis",
        "dahl_hysteresis@lower_arm",
        "dahl_hysteresis@top_mount",
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
        effects: Sequence[Effect] = (),
        design: np.ndarray | None = None,
        fit_parameters: Sequence[str] = FIT_PARAMETERS,
        tests: Sequence[str] = TESTS,
    ):
        for e in effects:
            check_effect(e)
        # host-declared parameters (lr_asymmetry) not given start at the K&C start value
        self.effects: tuple[Effect, ...] = tuple(
            e.with_params(
                {
                    p.name: float(p.default)
                    for p in fitted_parameters(e)
                    if p.name not in e.params and p.default is not None
                }
            )
            for e in effects
        )
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
        self.tests = tuple(tests)
        params = {p.name: p for p in fit_space(space).parameters}
        #: the space of ``theta`` (names, units, bounds) as the shared K&C fit maps it to
        #: the unit cube (:mod:`suspenv.rigs.knc_fit`: stiffnesses and positive effect
        #: parameters on a log scale)
        self.space = DesignSpace(
            [params[n] for n in self.fit_parameters]
            + [p for e in self.effects for p in effect_parameters(e)]
        )
        self._cache: OrderedDict[tuple, dict] = OrderedDict()
        self._rows: OrderedDict[tuple, tuple] = OrderedDict()

    # ------------------------------------------------------------------ names and bounds
    @property
    def base_names(self) -> tuple[str, ...]:
        return self.fit_parameters

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(self.space.names)

    @property
    def parameter_units(self) -> tuple[str, ...]:
        return tuple(p.unit for p in self.space.parameters)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.space.lower.copy(), self.space.upper.copy()

    def base_values(self) -> dict[str, float]:
        """Values of the fitted base parameters at the start design."""
        return {n: float(self.design[PARAMETER_NAMES.index(n)]) for n in self.fit_parameters}

    def initial_guess(self, rec: Recording | None = None) -> np.ndarray:
        return np.clip(self.theta_from(self.base_values(), self.effects), *self.bounds())

    def start_theta(self) -> np.ndarray:
        """``theta`` of the start design and each effect's K&C start value
        (:data:`KNC_EFFECTS`): the centre of the shared fit's pull
        (:func:`suspenv.rigs.knc_fit.polish`), the same whatever the fit starts from."""
        vals = [self.base_values()[n] for n in self.base_names]
        vals += [float(p.default or 0.0) for e in self.effects for p in fitted_parameters(e)]
        return np.array(vals, float)

    def _free(self, e: Effect) -> tuple[str, ...]:
        """Names of the parameters of effect ``e`` in ``theta`` (:func:`fitted_parameters`)."""
        return tuple(p.name for p in fitted_parameters(e))

    def unpack(self, theta: np.ndarray) -> tuple[dict[str, np.ndarray], list[Effect]]:
        """Base values (B,) per fitted parameter and effects with (B,) parameter arrays
        (one ``theta`` (p,) is a batch of one)."""
        return super().unpack(np.atleast_2d(self._checked_theta(theta)))

    def parts(self, theta: np.ndarray) -> tuple[dict[str, float], list[Effect]]:
        """Base values and effects (scalar parameters) of one ``theta`` (p,)."""
        base, effects = self.unpack(theta)
        scalar = [
            e.with_params({k: float(np.ravel(v)[0]) for k, v in e.params.items()}) for e in effects
        ]
        return {n: float(v[0]) for n, v in base.items()}, scalar

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
        force = [e for e in effects if e.spec.role == "force"]
        nan = {name: np.full((B, 2 * steps + 1), np.nan) for name in output_names()}
        out = {t: {k: v.copy() for k, v in nan.items()} for t in tests}
        messages = [""] * B
        for rows in same_rows(_effect_values(force, B)):  # one batch per solver effects
            eff = [
                e.with_params({k: _row_value(v, rows[0], B) for k, v in e.params.items()})
                for e in force
            ]
            eff_key = tuple((e.kind, e.location, tuple(sorted(e.params.items()))) for e in eff)
            keys = [
                (left[i].tobytes(), right[i].tobytes(), eff_key, amplitude, steps, tests)
                for i in rows
            ]
            self._solve_rows(left, right, rows, keys, eff, amplitude, steps, tests)
            for i, k in zip(rows, keys, strict=True):
                chans, msg = self._rows[k]
                messages[i] = msg
                for t, ch in chans.items():
                    for name, v in ch.items():
                        out[t][name][i] = v
            while len(self._rows) > 64:  # once the group is read: its rows may be the oldest
                self._rows.popitem(last=False)
        _apply_sensors(effects, out)
        result: dict[str, Any] = {"channels": out, "messages": messages}
        self._cache[key] = result
        if len(self._cache) > 6:
            self._cache.popitem(last=False)
        return result

    def _solve_rows(
        self,
        left: np.ndarray,
        right: np.ndarray,
        rows: list[int],
        keys: list[tuple],
        eff: list[Effect],
        amplitude: float,
        steps: int,
        tests: tuple[str, ...],
    ) -> None:
        """Run the rig ``tests`` (one kind: travel or force) on the design ``rows`` of
        ``left``/``right`` (n, 49) with the solver effects ``eff`` that are not yet held
        under their ``keys``, and hold each row's channels and message under its key."""
        todo = [i for i, k in zip(rows, keys, strict=True) if k not in self._rows]
        if not todo:
            return
        drives = ("amplitude", "force_amplitude", "moment_amplitude", "rack_amplitude")
        axle = build_axle(left[todo], right[todo])
        res = rig_run(axle, tests, steps, eff, dict.fromkeys(drives, amplitude))
        for j, i in enumerate(todo):
            msg = next((r.messages[j] for r in res.values() if not r.ok[j]), "")
            chans = {t: channels_of(r, j) for t, r in res.items()} if not msg else {}
            self._rows[keys[rows.index(i)]] = (chans, msg)

    def simulate(self, theta: np.ndarray, rec: Recording) -> dict[str, np.ndarray]:
        """Predicted outputs of recording ``rec``: ``(P,)`` per channel, or ``(B, P)``."""
        test = rig_test(rec)
        amp, steps = float(rec.meta["amplitude"]), int(rec.meta["steps"])
        # travel tests (amplitude in m), compliance tests (in N or N*m) and the steering
        # test (rack travel in m) run as separate batches
        kind = (test in FORCE_TESTS, test in STEER_TESTS, DRIVE_UNIT[test])
        same_kind = tuple(
            t for t in self.tests if (t in FORCE_TESTS, t in STEER_TESTS, DRIVE_UNIT[t]) == kind
        )
        tests = same_kind if test in same_kind else (test,)
        res = self._run(theta, amp, steps, tests)
        chans = res["channels"][test]
        if np.ndim(theta) == 1:
            if res["messages"][0]:
                raise EvaluationError(f"knc_axle: {res['messages'][0]}")
            return {k: v[0] for k, v in chans.items()}
        return {k: v.copy() for k, v in chans.items()}

    # ------------------------------------------------------------------ composition
    def with_effects(self, effects: Sequence[Effect]) -> KncAxleModel:
        return KncAxleModel(effects, self.design, self.fit_parameters, self.tests)

    def effect_words(self, effect: Effect) -> str:
        return effect_words(effect)

    def __repr__(self) -> str:
        effs = ", ".join(e.name for e in self.effects)
        return f"KncAxleModel(effects=[{effs}], fit={list(self.base_names)})"

    # ------------------------------------------------------------------ fit interface
    def difference_step(self, theta: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Forward-difference step ``max(3e-3 |theta|, 1e-3 (hi - lo))`` per parameter.

        The quasi-static solver converges to a tolerance, so its outputs are smooth in
        ``theta`` only down to that tolerance: the step must move the outputs well above
        it (a 1e-6 relative step would difference solver noise)."""
        theta = np.asarray(theta, float)
        return np.maximum(3e-3 * np.abs(theta), 1e-3 * (np.asarray(hi, float) - lo))
