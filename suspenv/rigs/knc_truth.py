"""Truth vehicles and blind cases on the K&C rig: "measured" rig recordings.

A truth vehicle is the test car (:func:`suspenv.models.mcpherson.truth.truth_vehicle`:
the reference axle, optionally with left/right manufacturing tolerances) with
concealed effects. The concealed force and sensor effects are the very
effects-library objects the fitted model takes
(:func:`~suspenv.rigs.knc_axle.make_candidate`, ``kind@location``), run through the
same solver and rig (:func:`suspenv.rigs.knc.run_tests`) and the same sensor
elements, so a :class:`~suspenv.rigs.knc_axle.KncAxleModel` holding the same effects
reproduces a truth's noise-free loops (tolerances aside). Sensor noise is Gaussian
(:data:`suspenv.models.mcpherson.truth.CHANNEL_NOISE`, scaled, seeded).

A truth is described by a mapping of its names (:data:`TRUTH_KIND`: ``hysteresis``,
``friction``, ``progressive``, ``asymmetry``, ``sensor_gain``, ``sensor_offset``) to
(partial) magnitudes, e.g. ``{"hysteresis": {"f_c": 100.0, "bushings": ["top_mount"]}}``;
:func:`truth_effects` turns it into the effects (missing values: :data:`TRUTH_DEFAULTS`)
and the tolerances. The blind cases (:func:`blind_case`) draw type, magnitudes,
hysteresis location and noise level from a seed. Recording format:
:mod:`suspenv.measurements.knc`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements import Recording
from suspenv.measurements.knc import RIG_TESTS, check_rig_tests, rig_test
from suspenv.measurements.knc_file import KncMeasurement, from_results
from suspenv.models.effects import Effect
from suspenv.models.mcpherson import bushings_at
from suspenv.models.mcpherson.effects import location_of
from suspenv.models.mcpherson.truth import (
    CHANNEL_NOISE,
    TOLERANCE,
    TruthVehicle,
    truth_vehicle,
)
from suspenv.rigs.knc import FORCE_AMPLITUDE, TESTS, KCResult, run_tests
from suspenv.rigs.knc_axle import make_candidate
from suspenv.rigs.knc_recording import to_recordings

#: the concealed effect each truth name stands for, at its default magnitude: the same
#: effects the fitted model takes (``hysteresis`` and ``progressive`` may name other
#: ``bushings``; ``asymmetry`` is the test car's tolerance, :data:`TOLERANCE`)
TRUTH_DEFAULTS: dict[str, Effect] = {
    "hysteresis": make_candidate("dahl_hysteresis", f_c=80.0),
    "friction": make_candidate("coulomb_friction", f_c=120.0),
    "progressive": make_candidate("cubic_stiffness", ratio=0.2),
    "sensor_gain": make_candidate("sensor_gain", gain=1.04),
    "sensor_offset": make_candidate("sensor_offset", offset=10.0),
}
#: the diagnosis' effect kind that names each concealed effect
TRUTH_KIND: dict[str, str] = {
    **{name: e.kind for name, e in TRUTH_DEFAULTS.items()},
    "asymmetry": "lr_asymmetry",
}


def truth_effects(
    effects: Mapping[str, Mapping[str, Any]],
) -> tuple[list[Effect], dict[str, float] | None]:
    """The concealed effects of a truth description and its left/right tolerance.

    Returns ``(effects, tolerance)``: effects-library elements in the order of
    :data:`TRUTH_DEFAULTS` (sensor gain before offset) with the given magnitudes, and
    the tolerances of an ``asymmetry`` truth (None without one).
    """
    unknown = sorted(set(effects) - set(TRUTH_KIND))
    if unknown:
        raise ValidationError(
            f"truth effects must be among {sorted(TRUTH_KIND)}, but got {unknown}"
        )
    out = []
    for name, default in TRUTH_DEFAULTS.items():
        if name not in effects:
            continue
        values = dict(effects[name])
        effect = default
        if "bushings" in values:
            where = location_of(tuple(values.pop("bushings")))
            effect = make_candidate(f"{default.kind}@{where}", **default.params)
        out.append(effect.with_params({k: float(v) for k, v in values.items()}))
    tolerance = None
    if "asymmetry" in effects:
        bad = sorted(set(effects["asymmetry"]) - set(TOLERANCE))
        if bad:
            raise ValidationError(
                f"truth asymmetry values must be among {sorted(TOLERANCE)}, but got {bad}"
            )
        tolerance = {k: float(v) for k, v in {**TOLERANCE, **effects["asymmetry"]}.items()}
    return out, tolerance


def measure_car(
    car: TruthVehicle,
    tests: Sequence[str],
    noise_seed: int,
    amplitude: float = 0.040,
    steps: int = 30,
    force_amplitude: float = FORCE_AMPLITUDE,
    sensors: Sequence[Effect] = (),
    noise_scale: float = 1.0,
) -> dict[str, KCResult]:
    """Rig results {test: KCResult} of a truth vehicle: the one way to measure one.

    ``car`` runs ``tests`` (``amplitude`` [m] travel stroke, ``force_amplitude`` [N]
    compliance force); ``sensors`` act on the channel each reads (both wheels), then each
    channel ``c`` of ``car.noise`` gets Gaussian noise of sigma ``noise_scale * car.noise[c]``
    (SI) from one stream seeded by ``noise_seed`` (tests, channels sorted). A test the car
    fails is refused."""
    results = run_tests(
        car.axle(), tuple(tests), amplitude, steps, car.effects, force_amplitude=force_amplitude
    )
    rng = np.random.default_rng(noise_seed)
    for test in sorted(results):
        res = results[test]
        if not res.ok.all():
            raise ValidationError(f"the truth vehicle fails the {test} test: {res.messages[0]}")
        for e in sensors:
            res.channels[e.location] = e.sensor(res.channels[e.location])
        for name in sorted(car.noise):
            ch = res.channels[name]
            res.channels[name] = ch + rng.normal(0.0, noise_scale * car.noise[name], ch.shape)
    return results


def measure_truth(
    effects: Mapping[str, Mapping[str, Any]] | None = None,
    seed: int = 0,
    amplitude: float = 0.040,
    steps: int = 8,
    noise_scale: float = 1.0,
    tests: Sequence[str] = TESTS,
    design: np.ndarray | None = None,
    force_amplitude: float = FORCE_AMPLITUDE,
) -> dict[str, Recording]:
    """ "Measured" K&C recordings of a truth vehicle with concealed ``effects`` (seeded).

    ``effects`` maps names of :data:`TRUTH_KIND` to (partial) magnitudes, e.g.
    ``{"hysteresis": {"f_c": 100.0}}``; ``{}`` is the plain reference vehicle.
    ``noise_scale`` multiplies the rig's sensor noise (``0`` gives exact loops; one
    noise stream, seed ``20_000 + seed``, :func:`measure_car`).
    ``amplitude`` [m] is the travel tests' stroke, ``force_amplitude`` [N] the
    compliance tests' force. Physics outside the K&C library is concealed in these
    recordings by the benchmark (``benchmarks/knc_truth.py``).
    """
    if noise_scale < 0:
        raise ValidationError(f"`noise_scale >= 0` must hold, but got {noise_scale}")
    concealed, tolerance = truth_effects(dict(effects or {}))
    tol = tolerance or TOLERANCE
    car = truth_vehicle(
        seed,
        base=design,
        tolerance=tolerance is not None,
        hard_point_tol_mm=tol["hard_point_tol_mm"],
        stiffness_tol=tol["stiffness_tol"],
        alignment_tol_deg=tol["alignment_tol_deg"],
        effects=[e for e in concealed if e.spec.role == "force"],
    )
    sensors = [e for e in concealed if e.spec.role == "sensor"]
    results = measure_car(
        car, tests, 20_000 + seed, amplitude, steps, force_amplitude, sensors, noise_scale
    )
    info = {"source": "suspenv truth vehicle (concealed effects)", "seed": int(seed)}
    return to_recordings(results, meta=info)


# ------------------------------------------------------------------ the built-in test car
#: effects the built-in test car can conceal (:func:`concealed_car`)
CONCEALED = ("hysteresis", "tolerance", "noise")


def concealed_car(seed: int = 0, concealed: Sequence[str] = CONCEALED) -> TruthVehicle:
    """The test car of ``KCIdentification`` and ``suspenv identify``: the reference
    vehicle with ``concealed`` among :data:`CONCEALED` (the default hysteresis, left/right
    tolerances drawn from ``seed``, the rig's sensor noise)."""
    bad = sorted(set(concealed) - set(CONCEALED))
    if bad:
        raise ValidationError(f"concealed effects must be among {CONCEALED}, but got {bad}")
    return truth_vehicle(
        seed,
        hysteresis="hysteresis" in concealed,
        tolerance="tolerance" in concealed,
        noise="noise" in concealed,
    )


def measure_tests(
    car: TruthVehicle, tests: Sequence[str], amplitude: float = 0.040, steps: int = 30
) -> dict[str, KCResult]:
    """Rig results {test: KCResult} of the test car in any rig ``tests`` (travel tests
    first, each in the order asked) with its noise (:func:`measure_car`): the three travel
    tests together from seed ``10_000 + car.seed`` (the data of ``KCIdentification``,
    whichever of them are asked), any other test at the rig's default load from seed
    ``20_000 + 100 * car.seed + RIG_TESTS.index(test)``."""
    check_rig_tests(tests)
    out: dict[str, KCResult] = {}
    if any(t in TESTS for t in tests):
        travel = measure_car(car, TESTS, 10_000 + car.seed, amplitude, steps)
        out.update({t: travel[t] for t in tests if t in TESTS})
    for t in tests:
        if t not in TESTS:
            noise_seed = 20_000 + 100 * car.seed + RIG_TESTS.index(t)
            out[t] = measure_car(car, (t,), noise_seed, amplitude, steps)[t]
    return out


def car_measurement(
    results: Mapping[str, KCResult], seed: int, concealed: Sequence[str]
) -> KncMeasurement:
    """The test car's results (:func:`measure_tests`) as a measurement declaring the rig's
    noise (:data:`~suspenv.models.mcpherson.truth.CHANNEL_NOISE`, the fit's weights, also
    when ``"noise"`` is not concealed)."""
    return from_results(
        results,
        f"test car (seed {seed}, concealed: {'+'.join(sorted(concealed)) or 'none'})",
        noise=dict(CHANNEL_NOISE),
        source="suspenv built-in test car (reference vehicle + concealed effects)",
    )


# ------------------------------------------------------------------ blind cases
BLIND_KINDS = (
    "hysteresis",
    "friction",
    "progressive",
    "asymmetry",
    "sensor_gain",
    "sensor_offset",
)
#: hysteresis locations of the blind cases: case word -> axle location
HYSTERESIS_LOCATIONS = {
    "all": "lower_arm_and_top_mount",
    "lower_arm": "lower_arm",
    "top_mount": "top_mount",
}
#: single-effect case types: every truth kind, the hysteresis at each location
SINGLE_TYPES = (*(f"hysteresis@{w}" for w in HYSTERESIS_LOCATIONS), *BLIND_KINDS[1:])
#: two-effect case types (fixed pairs covering every kind)
PAIR_TYPES = (
    "hysteresis@lower_arm+sensor_gain",
    "friction+asymmetry",
    "progressive+sensor_offset",
    "hysteresis@all+asymmetry",
    "friction+sensor_gain",
    "hysteresis@top_mount+sensor_offset",
)
#: the fixed cycle of case types: seed -> ``BLIND_PLAN[seed % len(BLIND_PLAN)]``; any
#: ``len(BLIND_PLAN)`` consecutive seeds hold each single type 3 times, each pair once
#: and 6 no-effect controls (36 cases)
BLIND_PLAN: tuple[str, ...] = tuple(
    t
    for i in range(6)
    for t in (
        SINGLE_TYPES[(4 * i) % 8],
        "none",
        SINGLE_TYPES[(4 * i + 1) % 8],
        PAIR_TYPES[i],
        SINGLE_TYPES[(4 * i + 2) % 8],
        SINGLE_TYPES[(4 * i + 3) % 8],
    )
)


def case_type(seed: int) -> str:
    """The blind case type of ``seed``: ``"none"``, a kind (``"friction"``,
    ``"hysteresis@top_mount"`` ...) or two joined by ``+`` (see :data:`BLIND_PLAN`)."""
    return BLIND_PLAN[int(seed) % len(BLIND_PLAN)]


def _draw_effect(kind: str, rng: np.random.Generator) -> tuple[str, dict[str, Any]]:
    """One concealed effect of ``kind`` (``name[@location]``) with a random magnitude."""
    name, _, where = kind.partition("@")
    if name == "hysteresis":
        return name, {
            "f_c": float(rng.uniform(50.0, 150.0)),
            "bushings": list(bushings_at(HYSTERESIS_LOCATIONS[where or "all"])),
        }
    if name == "friction":
        return name, {"f_c": float(rng.uniform(60.0, 250.0))}
    if name == "progressive":
        return name, {"ratio": float(rng.uniform(0.1, 0.5))}
    if name == "asymmetry":
        s = float(rng.uniform(0.6, 1.5))
        return name, {
            "hard_point_tol_mm": 1.0 * s,
            "stiffness_tol": 0.10 * s,
            "alignment_tol_deg": 0.05 * s,
        }
    if name == "sensor_gain":
        return name, {"gain": float(1.0 + rng.choice([-1, 1]) * rng.uniform(0.02, 0.06))}
    if name == "sensor_offset":
        return name, {"offset": float(rng.choice([-1, 1]) * rng.uniform(3.0, 20.0))}
    raise ValidationError(f"blind effect kinds must be among {BLIND_KINDS}, but got {kind!r}")


def blind_truth(seed: int) -> dict[str, Any]:
    """Concealed effects of blind case ``seed``: the type from :func:`case_type`,
    magnitudes, hysteresis location and noise level drawn from the seed."""
    rng = np.random.default_rng(seed)
    ctype = case_type(seed)
    effects: dict[str, dict[str, Any]] = {}
    for kind in [] if ctype == "none" else ctype.split("+"):
        name, values = _draw_effect(kind, rng)
        effects[name] = values
    return {
        "seed": int(seed),
        "case_type": ctype,
        "effects": effects,
        "expected_kinds": sorted(TRUTH_KIND[k] for k in effects),
        "noise_scale": float(rng.uniform(0.5, 2.0)),
    }


#: rig tests of a blind case: the three travel tests and the two compliance tests
BLIND_TESTS = (*TESTS, "lateral", "longitudinal")


def blind_case(
    seed: int, steps: int = 8, amplitude: float = 0.040, tests: Sequence[str] = BLIND_TESTS
) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(case, truth)``: the case holds only the recordings; the truth is kept apart."""
    truth = blind_truth(seed)
    recs = measure_truth(
        truth["effects"], seed, amplitude, steps, noise_scale=truth["noise_scale"], tests=tests
    )
    case: dict[str, Any] = {
        "id": f"knc-blind-{seed}",
        "recordings": {t: r for t, r in recs.items()},
    }
    for r in case["recordings"].values():
        r.meta.pop("seed", None)
        r.name = f"knc-blind-{seed}:{rig_test(r)}"
    return case, truth
