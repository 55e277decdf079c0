"""``suspenv identify``: a McPherson axle's parameters from measured K&C curves.

The job (:func:`run_identify`):

1. read the measurement (:class:`suspenv.measurements.knc_file.KncMeasurement`: SI,
   raw ISO 8855, both wheels, both loading branches) and the vehicle file (its design
   is the start, its ``[bounds]`` the identification box, its constants and bushing
   orientations are held);
2. fit the whole curves, weighted by each channel's noise (:mod:`.curve_fit`: CMA-ES,
   then least squares with the batched Jacobian);
3. judge what the data identify (:mod:`.identifiability`) and which rig test suspenv
   simulates would identify the rest; on the built-in test car, measure that test too
   (same noise model) and fit again to show the gain;
4. screen the remaining residual with the K&C diagnosis' signatures
   (:mod:`suspenv.diagnosis.knc.signatures`: hysteresis loop, left/right asymmetry,
   progressive stiffness, load-cell gain and offset);
5. write ``identified.toml`` (a vehicle file), ``report.md`` with figures and
   ``identify.json`` into the output folder (:mod:`suspenv.reports.identify`).

``method = "tey2014"`` runs the paper's pipeline on the measured targets instead
(:mod:`suspenv.methods.tey2014.pipeline`).

The built-in test car (:func:`measure_test_car`): the reference vehicle plus concealed
effects (:func:`suspenv.rigs.knc_truth.concealed_car`), measured through the
same :class:`~suspenv.measurements.knc_file.KncMeasurement` path as a file.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.laps import Laps
from suspenv.core.space import DesignSpace, Parameter
from suspenv.methods.curves.curve_fit import (
    CurveFit,
    CurveModel,
    MeasuredCurves,
    fit_curves,
    measured_curves,
)
from suspenv.methods.curves.identifiability import (
    CandidateGain,
    Identifiability,
    assess,
    rank_tests,
)
from suspenv.methods.curves.knc_sheet import SHEET_TESTS, SheetRow, knc_sheet, sheet_values
from suspenv.methods.curves.model_loop import Refinement, refine
from suspenv.models.mcpherson.params import AxleConstants, paper_initial_values
from suspenv.models.mcpherson.truth import CHANNEL_NOISE, TruthVehicle
from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, VehicleFile, load_vehicle
from suspenv.rigs.knc_fit import (
    PRIOR_WEIGHT,
    StageResult,
    amplitude_kwargs,
    polish,
    rig_run,
    say,
)
from suspenv.rigs.knc_truth import CONCEALED, car_measurement, concealed_car, measure_tests
from suspenv.runs.config import plots_wanted
from suspenv.runs.run_dir import write_json

METHODS = ("curves", "tey2014")
SIDES_OPTIONS = ("symmetric", "both")
#: a curve is fitted when its RMS residual is within this many noise RMS
FIT_RATIO = 1.5
INITIALS = ("vehicle", "paper")
#: vehicle constants fitted when the measurement holds a test that sees them: the
#: steering system's compliance (rack-housing mounts, column torsion), which the
#: aligning test loads and the steering test moves (name -> (unit, tests))
FITTED_CONSTANTS = {
    "rack_mount_rate": ("N/mm", ("steering", "aligning")),
    "column_torsion_rate": ("N*m/deg", ("steering", "aligning")),
}
#: a fitted constant's box: the vehicle file's value divided and multiplied by this
CONSTANT_RANGE = 10.0
#: the job's options and defaults (``[identify]`` of a config, CLI flags)
DEFAULTS: dict[str, Any] = {
    "method": "curves",
    "initial": "auto",  # "vehicle" (the file's design) or "paper"; auto: paper for test-car
    "free": [],  # parameters fitted (empty: all)
    "sides": "symmetric",  # or "both": a right-side twin of every free parameter but the bar
    "global_evaluations": 640,  # CMA-ES budget; 0: least squares from the start only (see docs)
    "popsize": 32,
    "sigma0": 0.2,
    "polish_nfev": 150,
    "workers": 2,  # processes: the polish from the start runs beside the global stage
    "next_test": True,
    "rerun_next": True,
    "diagnose": True,
    "loop": True,  # add what the residual screen names (sides apart, an effect) and refit
    "loop_nfev": 250,  # secant steps of each near-tied place's refit (path-dependent: slow)
    "sheet": True,  # the identified car's K&C sheet with 95 % intervals
    "held_out": "",  # a rig test kept out of the fit and predicted ("": none; "auto")
    "figures": True,
}
#: a residual signature scoring above this names its pattern (scores are about N(0, 1)
#: under pure noise; 5 keeps the chance of a false name per run below about 1 %, where
#: the diagnosis' own screen uses 3 only to pick candidates for a likelihood-ratio refit)
SIGNATURE_THRESHOLD = 5.0
#: ... and holds at least this share of the residual's sum of squares (noise units).
#: Far above the noise a score says only that a pattern is there, not that it matters:
#: a left/right difference or a hysteresis loop 30 times the noise leaves significant
#: cubic and load-proportional parts that a refit of those elements would not explain
NAMED_SHARE = 0.05


def cpu_seconds() -> float:
    """CPU time [s] of this process and of its finished child processes (the polish that
    runs beside the global stage)."""
    t = os.times()
    return time.process_time() + t.children_user + t.children_system


def check_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """Options merged over :data:`DEFAULTS`; every key and value checked."""
    from suspenv.core import options as check
    from suspenv.measurements.knc import RIG_TESTS

    who = "identify"
    check.check_keywords(who, options, DEFAULTS)
    o = {**DEFAULTS, **dict(options)}
    choices = {
        "method": METHODS,
        "initial": (*INITIALS, "auto"),
        "sides": SIDES_OPTIONS,
        # "auto": the test the fit determines best; "": none
        "held_out": ("", "auto", *RIG_TESTS),
    }
    for key, allowed in choices.items():
        o[key] = check.choice(who, key, o[key], allowed)
    least = {"global_evaluations": 0, "popsize": 4, "polish_nfev": 1, "workers": 1, "loop_nfev": 1}
    for key, lo in least.items():
        o[key] = check.integer(who, key, o[key], lo)
    o["sigma0"] = check.number(who, "sigma0", o["sigma0"], 0.0, 1.0, lo_open=True)
    o["free"] = list(check.texts(who, "free", o["free"]))
    for key in ("next_test", "rerun_next", "diagnose", "loop", "sheet", "figures"):
        o[key] = check.flag(who, key, o[key])
    return o


# ------------------------------------------------------------------ the test car
def measure_test_car(
    seed: int = 0,
    concealed: Sequence[str] = CONCEALED,
    tests: Sequence[str] = ("parallel", "opposite", "single"),
    amplitude: float = 0.040,
    steps: int = 30,
    constants: AxleConstants | None = None,
) -> tuple[Any, TruthVehicle]:
    """The built-in test car measured through the measured-K&C path: (KncMeasurement,
    truth) (:func:`suspenv.rigs.knc_truth.measure_tests`,
    :func:`~suspenv.rigs.knc_truth.car_measurement`); ``constants``: the car's
    (default: the reference car's)."""
    truth = concealed_car(seed, concealed)
    if constants is not None:
        truth = dataclasses.replace(truth, constants=constants)
    results = measure_tests(truth, tests, amplitude, steps)
    return car_measurement(results, seed, concealed), truth


def paper_initial(space: DesignSpace) -> np.ndarray:
    """The paper's initial model: hard points at the centres of its ranges, every bushing
    stiffness 500, anti-roll bar 300, camber and toe 0 (clipped into ``space``)."""
    x = space.from_dict(paper_initial_values())
    return np.clip(x, space.lower, space.upper)


# ------------------------------------------------------------------ the job
@dataclass
class Rerun:
    """The fit repeated with the recommended test's data added (built-in test car)."""

    test: str
    fit: CurveFit
    identifiability: Identifiability
    seconds: float


@dataclass
class HeldOut:
    """A rig test kept out of the fit and predicted: RMS / noise per channel (both
    wheels, both branches) by the first fit and by the loop's refit."""

    test: str
    source: str
    before: dict[str, float]
    after: dict[str, float]
    #: ``held_out = "auto"``: every candidate test's predicted-curve standard deviation
    #: at the start design under the others' covariance, worst channel, noise units
    #: (:func:`choose_held_out`; the least is held out); empty when the test was named
    choice: dict[str, float] = field(default_factory=dict)

    @property
    def why(self) -> str:
        """Why this test was held out."""
        if not self.choice:
            return "named in the options"
        return (
            "the candidate the fitted tests determine best at the start design: its "
            "predicted curves' standard deviation under the covariance of a fit to the "
            f"others (delta method, worst channel) is {self.choice[self.test]:.3g} x its "
            "noise, the least of " + ", ".join(f"{t} {v:.3g}" for t, v in self.choice.items())
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "test": self.test,
            "source": self.source,
            "why": self.why,
            "predicted_sd_over_noise": self.choice,
            "rms_over_noise_before": self.before,
            "rms_over_noise_after": self.after,
            "worst_before": max(self.before.values()),
            "worst_after": max(self.after.values()),
        }


@dataclass
class IdentifyResult:
    """Everything the job computed (input of :mod:`suspenv.reports.identify`)."""

    measurement: Any
    vehicle: VehicleFile
    options: dict[str, Any]
    model: CurveModel
    x0: np.ndarray
    fit: CurveFit
    identifiability: Identifiability
    initial_residual: np.ndarray
    candidates: list[CandidateGain] = field(default_factory=list)
    rerun: Rerun | None = None
    diagnosis: dict[str, Any] | None = None
    truth_vehicle: TruthVehicle | None = None
    loop: Refinement | None = None
    loop_identifiability: Identifiability | None = None
    loop_diagnosis: dict[str, Any] | None = None
    held_out: HeldOut | None = None
    sheet: list[SheetRow] = field(default_factory=list)
    sheet_truth: dict[str, np.ndarray] | None = None
    truth: np.ndarray | None = None
    timings: dict[str, float] = field(default_factory=dict)
    cpu_seconds: float = 0.0
    start: str = "the vehicle file's design"

    @property
    def final_fit(self) -> CurveFit:
        """The answer: the loop's refit when the loop ran, else the first fit."""
        return self.loop.fit if self.loop is not None else self.fit

    @property
    def final_identifiability(self) -> Identifiability:
        return self.loop_identifiability or self.identifiability

    @property
    def identified_vehicle(self) -> VehicleFile:
        v = self.vehicle
        fit = self.final_fit
        x = fit.model.full(fit.x)[0]
        d = fit.model.space.dim
        right = x[d : 2 * d] if fit.model.two_sided else x[:d]
        return VehicleFile(
            f"{v.name} identified",
            x[:d].copy(),
            right.copy(),
            fit.model.constants_at(x),
            fit.model.effects_at(x),
            f"identified by suspenv identify from {self.measurement.name}",
            dict(v.bounds),
            dict(v.orientation),
        )

    def curve_rms(self, r: np.ndarray | None = None) -> dict[tuple[str, str], float]:
        """RMS residual / noise per (test, channel), both wheels."""
        return self.model.block_rms(self.fit.residual if r is None else r)


def build_model(
    measurement: Any,
    vehicle: VehicleFile,
    x0: np.ndarray,
    free: Sequence[str] | None = None,
    two_sided: bool = False,
) -> CurveModel:
    """The :class:`CurveModel` of a measurement on a vehicle (its space, constants,
    orientation, effects); the tests the rig cannot simulate are refused."""
    from suspenv.measurements.knc import check_rig_tests

    check_rig_tests(tuple(measurement.tests))
    tests = []
    for name, mt in measurement.tests.items():
        wheels = tuple(getattr(mt, "wheels", ("left", "right")))
        if len(wheels) < 2:
            raise ValidationError(
                f"identify: test {name!r} must hold both wheels, but holds {list(wheels)}"
            )
        steps = measurement.meta.get("steps", {}).get(name)
        tests.append(measured_curves(mt, steps))
    return CurveModel(
        tests,
        measurement.noise,
        vehicle.space(),
        x0,
        free or None,
        vehicle.constants,
        vehicle.effects,
        two_sided=two_sided,
        orientation=vehicle.orientation,
        travel_drive=measurement.meta.get("travel_drive", "pad"),
        effect_free=fitted_constants(vehicle, measurement.tests),
    )


def fitted_constants(vehicle: VehicleFile, tests: Sequence[str]) -> list[Parameter]:
    """The vehicle constants (:data:`FITTED_CONSTANTS`) that ``tests`` see, as fitted
    values ``constants.<name>``: the vehicle file's value divided and multiplied by
    :data:`CONSTANT_RANGE` as bounds, on a log scale."""
    out = []
    for name, (unit, seen_by) in FITTED_CONSTANTS.items():
        if any(t in tests for t in seen_by):
            v = float(getattr(vehicle.constants, name))
            low, high = v / CONSTANT_RANGE, v * CONSTANT_RANGE
            out.append(Parameter(f"constants.{name}", low, high, unit, True, v))
    return out


def _simulated_tests(
    model: CurveModel, x: np.ndarray, tests: Sequence[str]
) -> list[MeasuredCurves]:
    """Candidate tests simulated at design ``x`` as if measured (channels of the model)."""
    from suspenv.measurements.knc import branch_index

    kw = {"amplitude": model.travel_amplitude}  # the other tests at the rig's own loads
    steps = model.tests[0].steps
    res = rig_run(model.axle(x[None]), tests, steps, model.effects, kw, model.travel_drive)
    out = []
    channels = sorted(model.sigma)
    for t, r in res.items():
        if not r.ok[0]:
            continue
        drive = r.grid[r.path]
        vals = {c: r.channels[c][0] for c in channels if c in r.channels}
        out.append(
            MeasuredCurves(
                t, drive, branch_index(steps).astype(int), vals, float(r.grid[-1]), steps
            )
        )
    return out


def candidate_jacobians(model: CurveModel, u: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """Jacobians (noise-scaled, in the fit's unit cube) at ``u`` of every rig test the
    measurement lacks, the opposed compliance tests included (a rig runs them; they load
    the two sides in another combination than the in-phase tests), per
    channel: {test: {channel: (N_tc, dim)}}, all tests in one batched evaluation."""
    from suspenv.measurements.knc import RIG_TESTS

    have = {t.test for t in model.tests}
    missing = [t for t in RIG_TESTS if t not in have]
    x = model.designs(u[None])[0]
    sims = _simulated_tests(model, x, missing) if missing else []
    if not sims:
        return {}
    other = model.variant(tests=sims)
    return other.by_test(other.jacobian(u)[1])


def choose_held_out(
    blocks: Mapping[str, Mapping[str, np.ndarray]],
    measured: Sequence[str],
    candidates: Sequence[str],
) -> tuple[str, dict[str, float]]:
    """The rig test to hold out: the candidate whose curves the others determine best.

    ``blocks``: {test: {channel: Jacobian (N, dim)}} (noise-scaled, unit cube, one
    design) of the measured tests and the candidates; ``measured``: the tests the fit
    can use. A candidate's covariance is that of a fit to the measured tests other than
    itself with the polish's weak pull towards the start, ``(J'J + w^2 I)^-1`` (``w``
    :data:`~suspenv.rigs.knc_fit.PRIOR_WEIGHT`: a direction no curve sees is known
    to the whole range); a channel's predicted-curve standard deviation in noise units
    is the delta method's ``sqrt(mean_i J_i C J_i')`` over its samples, a test's score
    its worst channel's (the held-out test is judged by its worst channel). Returns the
    candidate of the least score and every candidate's score. A test the fitted ones
    leave undetermined says little when it misses or when it hits."""
    scores = {}
    for test in candidates:
        rest = [J for t in measured if t != test for J in blocks[t].values()]
        if not rest:
            continue
        A = np.vstack(rest)
        cov = np.linalg.inv(A.T @ A + PRIOR_WEIGHT**2 * np.eye(A.shape[1]))
        scores[test] = max(
            float(np.sqrt(np.mean(np.einsum("ij,jk,ik->i", J, cov, J))))
            for J in blocks[test].values()
        )
    if not scores:
        raise ValidationError(
            "identify: `held_out = 'auto'` needs a test left to fit, but the measurement "
            f"holds only {list(measured)}"
        )
    return min(scores, key=lambda t: scores[t]), scores


def auto_held_out(
    measurement: Any,
    vehicle: VehicleFile,
    x0: np.ndarray,
    truth: TruthVehicle | None,
    free: Sequence[str] = (),
) -> tuple[str, dict[str, float]]:
    """:func:`choose_held_out` at the start design ``x0``, before any fit. Candidates:
    the measurement's own tests (the fit then uses the others) and, on the built-in test
    car (``truth``), the rig tests it was not measured in (it can be measured in them,
    the fit keeps all its data). One batched Jacobian per set of tests."""
    model = build_model(measurement, vehicle, x0, free)
    u0 = model.unit(x0)
    blocks = model.by_test(model.jacobian(u0)[1])
    extra = {} if truth is None else candidate_jacobians(model, u0)
    measured = list(measurement.tests)
    return choose_held_out({**blocks, **extra}, measured, [*measured, *extra])


def screen_residual(model: CurveModel, measurement: Any, x: np.ndarray) -> dict[str, Any]:
    """The K&C diagnosis' residual screen at design ``x``: residual map (test x channel
    x branch x side, in noise units estimated from the residual's roughness) and the
    signature scores (about N(0, 1) under pure noise). Named stepwise: the strongest
    score above :data:`SIGNATURE_THRESHOLD` whose pattern holds at least
    :data:`NAMED_SHARE` of the residual's sum of squares is named, its pattern projected
    out of the residual (:func:`~suspenv.diagnosis.knc.signatures.without_pattern`) and
    the others scored again."""
    from suspenv.diagnosis.knc.locate import residual_map
    from suspenv.diagnosis.knc.signatures import FAMILY_KINDS, FAMILY_WORDS, score_signatures
    from suspenv.measurements.knc import CHANNELS as REC_CHANNELS

    runs = _screen_runs(model, measurement, x)
    if isinstance(runs, str):
        return {"skipped": runs}
    recs, res, pred = runs
    scales = {}
    for name, (rig_name, _, _) in REC_CHANNELS.items():
        for s in ("left", "right"):
            scales[f"{name}_{s}"] = float(model.sigma.get(rig_name, 1.0))
    # the screen reads the residual in units of at least the measurement noise the fit
    # was weighted by: a residual below it (a fit to noise-free curves) names nothing
    where = residual_map(recs, res, scales, floor=scales)
    sigs = score_signatures(recs, res, pred, where.noise)
    named, shares = _name_stepwise(recs, res, pred, where.noise)
    first = {g.kind: g.score for g in sigs}
    return {
        "residual_map": where.to_dict(),
        "signatures": [g.to_dict() for g in sigs],
        "named": [
            {
                "family": g.kind,
                "score": g.score,
                "first_score": first[g.kind],
                "share_of_residual": sh,
                "kinds": list(FAMILY_KINDS[g.kind]),
                "words": FAMILY_WORDS[g.kind],
                "evidence": g.evidence,
            }
            for g, sh in zip(named, shares, strict=True)
        ],
        "threshold": SIGNATURE_THRESHOLD,
        "named_share": NAMED_SHARE,
        "rule": "stepwise: the strongest signature above the threshold is named when its "
        f"pattern holds at least {NAMED_SHARE:.0%} of the residual's sum of squares; it is "
        "projected out and the rest scored again",
    }


def _screen_runs(
    model: CurveModel, measurement: Any, x: np.ndarray
) -> tuple[list[Any], list[dict[str, np.ndarray]], list[dict[str, np.ndarray]]] | str:
    """Per test of ``model``: the measured recording, the residual (measured - simulated
    at ``x``) and the simulated channels; or why the screen cannot read the measurement."""
    from suspenv.measurements.knc import CHANNELS as REC_CHANNELS
    from suspenv.rigs.knc_measured import on_grid
    from suspenv.rigs.knc_recording import channels_of, to_recording

    recs, res, pred = [], [], []
    for t in model.tests:
        mt = measurement.tests[t.test]
        try:
            meas = on_grid(mt, t.steps)
        except ValidationError as exc:
            return f"test {t.test}: {exc}"
        if not all(ch in meas.channels for ch, _, _ in REC_CHANNELS.values()):
            return f"test {t.test} lacks a channel the screen reads"
        amps = amplitude_kwargs(t.test, t.amplitude)
        sim = rig_run(
            model.axle(x[None]), (t.test,), t.steps, model.effects_at(x), amps, model.travel_drive
        )[t.test]
        rec = to_recording(meas)
        p = channels_of(sim)
        recs.append(rec)
        pred.append(p)
        res.append({k: rec.outputs[k] - p[k] for k in p})
    return recs, res, pred


def _name_stepwise(
    recs: list[Any],
    res: list[dict[str, np.ndarray]],
    pred: list[dict[str, np.ndarray]],
    noise: Mapping[str, float],
) -> tuple[list[Any], list[float]]:
    """The signatures named stepwise (see :func:`screen_residual`) and the share of the
    residual's sum of squares (in ``noise`` units) each took out."""
    from suspenv.diagnosis.knc.signatures import FAMILY_KINDS, score_signatures, without_pattern

    # stepwise: name the strongest pattern, take it out of the residual, score again
    def sumsq(rr: Sequence[Mapping[str, np.ndarray]]) -> float:
        return float(sum(np.sum((v / noise[k]) ** 2) for r in rr for k, v in r.items()))

    total = sumsq(res)
    named: list[Any] = []
    shares: list[float] = []
    left = [dict(r) for r in res]
    for _ in range(len(FAMILY_KINDS)):
        done = {n.kind for n in named}
        again = [g for g in score_signatures(recs, left, pred, noise) if g.kind not in done]
        if not again or again[0].score <= SIGNATURE_THRESHOLD:
            break
        rest = without_pattern(recs, left, pred, noise, again[0].kind)
        share = (sumsq(left) - sumsq(rest)) / total if total > 0 else 0.0
        if share < NAMED_SHARE:
            break
        named.append(again[0])
        shares.append(share)
        left = rest
    return named, shares


#: an estimated noise below this fraction of the rig's typical sensor noise
#: (:data:`~suspenv.models.mcpherson.truth.CHANNEL_NOISE`) is taken for data smoother
#: than any rig records (simulated, or smoothed before export)
NOISE_PLAUSIBLE_FRACTION = 0.1


def fit_weights(measurement: Any) -> Any:
    """The measurement with weights the fit can trust: a channel whose noise was
    *estimated* (none declared) below :data:`NOISE_PLAUSIBLE_FRACTION` x the rig's
    typical sensor noise gets that typical noise instead (noise source ``"rig default:
    the data are smoother than a rig records"``): noise-free curves would otherwise
    weigh round-off as signal and claim every parameter identified. Declared noise is
    kept as it is. Returns a shallow copy; ``measurement`` is not changed."""
    noise = dict(measurement.noise)
    source = dict(measurement.noise_source)
    for c, sigma in measurement.noise.items():
        typical = CHANNEL_NOISE.get(c)
        if typical is None or source.get(c, "estimated") != "estimated":
            continue
        if not sigma >= NOISE_PLAUSIBLE_FRACTION * typical:
            noise[c] = float(typical)
            source[c] = "rig default: the data are smoother than a rig records"
    return dataclasses.replace(measurement, noise=noise, noise_source=source)


def run_identify(
    measurement: Any,
    vehicle: VehicleFile,
    options: Mapping[str, Any] | None = None,
    truth: TruthVehicle | None = None,
    progress: bool = False,
    seed: int = 1,
    x0: np.ndarray | None = None,
) -> IdentifyResult:
    """The whole-curve identification (see the module docstring); writes nothing.

    ``x0``: the start design (49,) in file units, overriding ``options["initial"]``."""
    opts = check_options(options or {})
    measurement = fit_weights(measurement)
    t_start, c_start = time.perf_counter(), cpu_seconds()
    lap = Laps()
    timings = lap.times

    x0, start = _start_design(vehicle, opts["initial"], truth, x0)
    two = opts["sides"] == "both"
    held_out: str = opts["held_out"]
    choice: dict[str, float] = {}
    if held_out == "auto":
        say(progress, "held-out test: the one the others determine best (at the start)")
        held_out, choice = auto_held_out(measurement, vehicle, x0, truth, opts["free"])
        lap("held_out_choice")
    measurement, held, held_source = split_held_out(measurement, held_out, truth)
    model = build_model(measurement, vehicle, x0, opts["free"], two)
    say(
        progress,
        f"identify: {len(model.tests)} tests, {len(model.sigma)} channels, {model.size} "
        f"residuals, {model.dim} parameters",
    )
    r0 = model.residual_at(x0, "the initial design")
    lap("setup")

    fit = _fit(model, x0, opts, seed, progress, timings)
    lap.restart()  # the fit's stages timed themselves (staged)
    truth_x = None if truth is None else truth.mean_design
    truth_map = _truth_map(truth, model)
    ident = assess(fit.jacobian, fit.residual, fit.u, model.sub, truth_map)
    lap("identifiability")
    result = IdentifyResult(
        measurement,
        vehicle,
        opts,
        model,
        x0,
        fit,
        ident,
        r0,
        truth=truth_x,
        timings=timings,
        start=start,
        truth_vehicle=truth,
    )
    _after_fit(result, truth_map, progress, lap)
    if held is not None:
        result.held_out = predict_held_out(result, held, held_source, choice)
        lap("held_out")
    if opts["sheet"]:
        say(progress, "K&C sheet: the identified car's metrics with 95 % intervals")
        _sheet(result)
        lap("sheet")
    timings["total"] = time.perf_counter() - t_start
    result.cpu_seconds = cpu_seconds() - c_start
    return result


def _fit(
    model: CurveModel,
    x0: np.ndarray,
    opts: dict[str, Any],
    seed: int,
    progress: bool,
    timings: dict[str, float],
) -> CurveFit:
    """:func:`fit_curves` from ``x0`` with the options' budgets; the seconds of its stages
    added to ``timings`` by kind."""

    def staged(s: StageResult) -> None:  # seconds per kind of stage (global, race, polish)
        key = s.name.split(" ")[0]
        timings[key] = timings.get(key, 0.0) + s.seconds

    return fit_curves(
        model,
        x0,
        opts["global_evaluations"],
        opts["popsize"],
        float(opts["sigma0"]),
        opts["polish_nfev"],
        seed,
        progress,
        staged,
        workers=opts["workers"],
    )


def _start_design(
    vehicle: VehicleFile, initial: str, truth: TruthVehicle | None, x0: np.ndarray | None
) -> tuple[np.ndarray, str]:
    """The start design (49,) in file units and words saying what it is: ``x0`` when
    given (checked against the bounds), else the ``initial`` option's design ("auto":
    the paper's initial model with a test car, else the vehicle file's design)."""
    space = vehicle.space()
    if initial == "auto":
        initial = "paper" if truth is not None else "vehicle"
    start = {"paper": "the paper's initial model", "vehicle": "the vehicle file's design"}[initial]
    if x0 is not None:
        start = "a given design"
        x0 = np.asarray(x0, float).copy()
        if x0.shape != (space.dim,) or space.outside_bounds(x0):
            raise ValidationError(
                f"identify: the start design must be {space.dim} values inside the bounds, but "
                f"got shape {x0.shape}: {'; '.join(space.outside_bounds(x0)[:3])}"
            )
    elif initial == "paper":
        x0 = paper_initial(space)
    else:
        x0 = 0.5 * (vehicle.left + vehicle.right)
    return x0, start


def _after_fit(
    result: IdentifyResult, truth_map: dict[str, float] | None, progress: bool, lap: Laps
) -> None:
    """The steps the options ask for after the fit, each timed: the next test to
    measure, the residual screen and the model loop on what the screen names."""
    opts, model, fit = result.options, result.model, result.fit
    if opts["next_test"] and result.identifiability.not_identified():
        say(progress, "next test: Jacobians of the rig tests not measured")
        _next_test(result, candidate_jacobians(model, fit.u), truth_map, progress)
        lap("next_test")
    if opts["diagnose"]:
        say(progress, "residual screen (K&C diagnosis signatures)")
        result.diagnosis = screen_residual(model, result.measurement, fit.x)
        lap("diagnosis")
    if opts["loop"] and result.diagnosis and result.diagnosis.get("named"):
        _model_loop(result, progress)
        lap("loop")


def _next_test(
    result: IdentifyResult,
    extra: Mapping[str, Mapping[str, np.ndarray]],
    truth_map: Mapping[str, float] | None,
    progress: bool,
) -> None:
    """The rig tests not measured ranked (``result.candidates``); on the test car, the
    best one measured too and the fit repeated from the answer (``result.rerun``)."""
    fit, model, opts = result.fit, result.model, result.options
    stacked = {t: np.vstack(list(ch.values())) for t, ch in extra.items()}
    result.candidates = rank_tests(result.identifiability, fit.jacobian, stacked, fit.u, model.sub)
    best = result.candidates[0] if result.candidates else None
    truth = result.truth_vehicle
    if truth is None or not opts["rerun_next"] or best is None:
        return
    say(progress, f"re-run with the {best.test} test added (test car, noisy)")
    t0 = time.perf_counter()
    more = measure_tests(truth, [best.test], model.travel_amplitude, model.tests[0].steps)
    from suspenv.measurements.knc_file import from_results

    added = from_results(more, "added", noise=dict(result.measurement.noise))
    both = _merged(result.measurement, added)
    model2 = build_model(both, result.vehicle, result.x0, opts["free"], model.two_sided)
    stage, r2, J2 = polish(  # from the answer (a test may add fitted constants)
        model2,
        model2.unit(fit.x),
        opts["polish_nfev"],
        progress=progress,
        prior=model2.unit(result.x0),
    )
    fit2 = CurveFit.of(model2, (stage, r2, J2))
    ident2 = assess(J2, r2, stage.u, model2.sub, dict(truth_map) if truth_map else None)
    result.rerun = Rerun(best.test, fit2, ident2, time.perf_counter() - t0)


def _truth_map(truth: TruthVehicle | None, model: CurveModel) -> dict[str, float] | None:
    """The test car's values of ``model``'s fitted names: symmetric, the mean of its
    sides; two-sided, each side; an effect's parameter where the car has that effect
    at that place."""
    if truth is None:
        return None
    names = model.space.names
    left = truth.left if model.two_sided else truth.mean_design
    out = {n: float(v) for n, v in zip(names, left, strict=True)}
    out.update({f"{n}@right": float(v) for n, v in zip(names, truth.right, strict=True)})
    out.update({f"constants.{n}": float(getattr(truth.constants, n)) for n in FITTED_CONSTANTS})
    for e in model.effects:
        for t in truth.effects:
            if (t.kind, t.location) == (e.kind, e.location):
                out.update({f"{e.name}.{k}": float(np.ravel(v)[0]) for k, v in t.params.items()})
    return out


def _model_loop(result: IdentifyResult, progress: bool) -> None:
    """Add what the screen named, refit, judge and screen the refit (in ``result``)."""
    assert result.diagnosis is not None
    from suspenv.runs.executors import ProcessPool

    named = [n["family"] for n in result.diagnosis["named"]]
    with contextlib.ExitStack() as stack:
        pool = stack.enter_context(ProcessPool(1)) if result.options["workers"] > 1 else None
        ref = refine(
            result.fit,
            named,
            result.x0,
            result.options["polish_nfev"],
            result.options["loop_nfev"],
            say=lambda m: say(progress, m),
            pool=pool,
            progress=progress,
            screen=lambda model, x: [
                n["family"] for n in screen_residual(model, result.measurement, x).get("named", [])
            ],
        )
    if ref is None:
        return
    result.loop = ref
    f = ref.fit
    truth_map = _truth_map(result.truth_vehicle, ref.model)
    result.loop_identifiability = assess(f.jacobian, f.residual, f.u, ref.model.sub, truth_map)
    if result.options["diagnose"]:
        result.loop_diagnosis = screen_residual(ref.model, result.measurement, f.x)


def _sheet(result: IdentifyResult) -> None:
    """The K&C sheet of the answer (and, on the test car, the truth's metrics)."""
    from suspenv.rigs.knc_measured import measured_results

    fit = result.final_fit
    steps = max(t.steps for t in fit.model.tests)
    measured = measured_results(result.measurement, steps)
    result.sheet = knc_sheet(fit, result.final_identifiability.cov_unit, measured)
    tv = result.truth_vehicle
    if tv is not None:
        res = rig_run(
            tv.axle(), SHEET_TESTS, steps, tv.effects, {"amplitude": fit.model.travel_amplitude}
        )
        result.sheet_truth = {k: v[0] for k, v in sheet_values(res, tv.constants).items()}


def split_held_out(measurement: Any, test: str, truth: TruthVehicle | None) -> tuple[Any, Any, str]:
    """(the measurement fitted, the held-out test's measurement or None, its source).

    A test of the measurement is taken out of it; the test car measures a test it lacks
    (the same noise model, its own seeded stream); otherwise the rule is broken."""
    from suspenv.measurements.knc_file import from_results

    if not test:
        return measurement, None, ""
    if test in measurement.tests:
        if len(measurement.tests) < 2:
            raise ValidationError(
                f"identify: `held_out = {test!r}` would leave no test to fit (the measurement "
                f"holds only {list(measurement.tests)})"
            )
        rest = {k: v for k, v in measurement.tests.items() if k != test}
        held = dataclasses.replace(measurement, tests={test: measurement.tests[test]})
        return dataclasses.replace(measurement, tests=rest), held, "measured, kept out of the fit"
    if truth is None:
        raise ValidationError(
            f"identify: `held_out` must name a test of the measurement {list(measurement.tests)}"
            f" (or any rig test on the built-in test car), but got {test!r}"
        )
    steps = next(iter(measurement.meta.get("steps", {}).values()), 30)
    amplitude = next(iter(measurement.meta.get("amplitude", {}).values()), 0.040)
    more = measure_tests(truth, [test], float(amplitude), int(steps))
    held = from_results(more, f"held out: {test}", noise=dict(measurement.noise))
    return measurement, held, "the test car measured with the same noise model, not fitted"


def predict_held_out(
    result: IdentifyResult, held: Any, source: str, choice: Mapping[str, float] | None = None
) -> HeldOut:
    """RMS / noise per channel of the held-out test predicted by the first fit and by the
    answer (the loop's refit when it ran); ``choice``: the scores it was chosen by
    (:func:`choose_held_out`)."""
    curves = build_model(held, result.vehicle, result.x0).tests
    out = []
    for fit in (result.fit, result.final_fit):
        m = fit.model.variant(tests=curves)
        rms = m.block_rms(m.residual_at(fit.x, "the held-out test at the fitted design"))
        out.append({c: v for (_, c), v in rms.items()})
    return HeldOut(next(iter(held.tests)), source, out[0], out[1], dict(choice or {}))


def _merged(a: Any, b: Any) -> Any:
    """Measurement ``a`` with the tests of ``b`` added (``a``'s noise levels)."""
    meta = dict(a.meta)
    meta["steps"] = {**a.meta.get("steps", {}), **b.meta.get("steps", {})}
    meta["amplitude"] = {**a.meta.get("amplitude", {}), **b.meta.get("amplitude", {})}
    return dataclasses.replace(a, tests={**a.tests, **b.tests}, meta=meta)


def summary(result: IdentifyResult) -> dict[str, Any]:
    """The JSON-ready summary (``identify.json``)."""
    fit = result.fit
    rms = result.curve_rms()
    rms0 = result.curve_rms(result.initial_residual)
    ident = result.identifiability
    out: dict[str, Any] = {
        "measurement": result.measurement.name,
        "vehicle": result.vehicle.name,
        "method": "whole-curve noise-weighted fit (CMA-ES + least squares)",
        "options": result.options,
        "n_residuals": result.model.size,
        "n_parameters": result.model.dim,
        "noise": {c: result.model.sigma[c] for c in sorted(result.model.sigma)},
        "noise_source": {
            c: result.measurement.noise_source.get(c, "") for c in sorted(result.model.sigma)
        },
        "cost_initial": float(result.initial_residual @ result.initial_residual),
        "cost": fit.cost,
        "converged": fit.converged,
        "stages": [s.to_dict() for s in fit.stages],
        "curves": [
            {
                "test": t,
                "channel": c,
                "rms_over_noise": v,
                "initial_rms_over_noise": rms0[(t, c)],
                "within_1_5_noise": v <= FIT_RATIO,
            }
            for (t, c), v in rms.items()
        ],
        "curves_within_1_5_noise": int(sum(v <= FIT_RATIO for v in rms.values())),
        "n_curves": len(rms),
        "worst_curve_rms_over_noise": max(rms.values()),
        "identifiability": ident.to_dict(),
        "identified": [v.name for v in ident.verdicts if v.identified],
        "not_identified": [v.name for v in ident.verdicts if not v.identified],
        "timings_s": result.timings,
        "cpu_seconds": result.cpu_seconds,
    }
    if result.truth is not None:
        err = [v.error_pct for v in ident.verdicts if v.identified and v.error_pct is not None]
        allerr = [v.error_pct for v in ident.verdicts if v.error_pct is not None]
        out["recovery_error_pct_range"] = {
            "identified_max": max(err) if err else None,
            "identified_mean": float(np.mean(err)) if err else None,
            "all_mean": float(np.mean(allerr)) if allerr else None,
        }
    if result.candidates:
        out["next_tests"] = [g.to_dict() for g in result.candidates]
        out["next_test"] = result.candidates[0].test
    if result.rerun is not None:
        rr = result.rerun
        ident2 = rr.identifiability
        err2 = [v.error_pct for v in ident2.verdicts if v.identified and v.error_pct is not None]
        out["rerun"] = {
            "test": rr.test,
            "n_identified_before": int(ident.identified.sum()),
            "n_identified_after": int(ident2.identified.sum()),
            "identified_after": [v.name for v in ident2.verdicts if v.identified],
            "n_determined_before": ident.n_determined,
            "n_determined_after": ident2.n_determined,
            "identified_max_error_pct_range": max(err2) if err2 else None,
            "cost": rr.fit.cost,
            "n_residuals": rr.fit.model.size,
            "stop": rr.fit.final.stop,
            "worst_curve_rms_over_noise": max(rr.fit.model.block_rms(rr.fit.residual).values()),
            "seconds": rr.seconds,
        }
    if result.diagnosis is not None:
        out["diagnosis"] = result.diagnosis
    if result.loop is not None:
        out["loop"] = _loop_summary(result)
    if result.held_out is not None:
        out["held_out"] = result.held_out.to_dict()
    if result.sheet:
        out["sheet"] = _sheet_summary(result)
    return out


def _sheet_summary(result: IdentifyResult) -> dict[str, Any]:
    """The sheet's rows; on the test car, each row's truth and whether the 95 % interval
    holds it (per wheel), and the share of metrics whose intervals hold the truth."""
    rows = [r.to_dict() for r in result.sheet]
    truth = result.sheet_truth
    if truth is None:
        return {"rows": rows}
    hits = []
    for r in rows:
        t = truth.get(r["name"])
        if t is None or not np.all(np.isfinite([*t, *r["ci95_half_width"]])):
            continue  # no truth, or no interval (a loop width)
        inside = np.abs(np.asarray(r["identified"]) - t) <= np.asarray(r["ci95_half_width"])
        r["truth"] = t.tolist()
        r["truth_inside_ci95"] = inside.tolist()
        hits += inside.tolist()
    return {"rows": rows, "coverage": float(np.mean(hits)) if hits else None, "n_values": len(hits)}


def _loop_summary(result: IdentifyResult) -> dict[str, Any]:
    """The loop's part of ``identify.json``: what was added, each curve before and after."""
    assert result.loop is not None and result.loop_identifiability is not None
    ref = result.loop
    before = result.curve_rms()
    after = ref.model.block_rms(ref.fit.residual)
    ident = result.loop_identifiability
    out = {
        "changes": ref.changes,
        "candidates": [c.to_dict() for c in ref.candidates],
        "not_modelled": ref.skipped,
        "curves": [
            {"test": t, "channel": c, "before": before[(t, c)], "after": v}
            for (t, c), v in after.items()
        ],
        "curves_within_1_5_noise_before": int(sum(v <= FIT_RATIO for v in before.values())),
        "curves_within_1_5_noise_after": int(sum(v <= FIT_RATIO for v in after.values())),
        "worst_curve_rms_over_noise_after": max(after.values()),
        "n_parameters": ref.model.dim,
        "cost": ref.fit.cost,
        "stop": ref.fit.final.stop,
        "identified": [v.name for v in ident.verdicts if v.identified],
        "effects": [e.to_dict() for e in ref.model.effects_at(ref.fit.x)],
        "seconds": ref.seconds,
    }
    if result.loop_diagnosis is not None:
        out["diagnosis"] = result.loop_diagnosis
    return out


# ------------------------------------------------------------------ files
def resolve_vehicle(path: str | Path | None) -> VehicleFile:
    """``None`` or ``"reference"``: the shipped reference vehicle; else a vehicle file."""
    if path is None or str(path) == "reference":
        return load_vehicle(REFERENCE_FILE)
    return load_vehicle(Path(path))


def write_outputs(result: IdentifyResult, out: Path, figures: bool = True) -> list[Path]:
    """``identified.toml``, ``identify.json``, ``report.md`` (+ figures) into ``out``."""
    from suspenv.registry import report_function

    writer = report_function("identify")
    files: list[Path] = writer(result, Path(out), figures=figures)
    return files


# ------------------------------------------------------------------ the pipeline
def _identify_table(config: Mapping[str, Any]) -> dict[str, Any]:
    table = config.get("identify", {}) or {}
    if not isinstance(table, Mapping):
        raise ValidationError(f"config: `identify` must be a table, but got {table!r}")
    return check_options(table)


def _problem(config: Mapping[str, Any]) -> Any:
    from suspenv.registry import make_problem

    section = config.get("problem", {}) or {}
    name = section.get("name", "KCIdentification")
    if name != "KCIdentification":
        raise ValidationError(
            f"config: the identify pipeline identifies a K&C axle: `problem.name` must be "
            f"'KCIdentification', but got {name!r}"
        )
    return make_problem(name, **(section.get("options", {}) or {}))


def check_identify_config(config: dict[str, Any]) -> dict[str, Any]:
    """Check an "identify" config before any work: the ``[identify]`` table
    (:data:`DEFAULTS`) and the problem (``KCIdentification``: the built-in test car, or
    ``measurements`` and ``vehicle`` files, which are read and checked). Returns the
    config with every default filled in."""
    opts = _identify_table(config)
    _problem(config)
    if opts["method"] == "tey2014":
        from suspenv.registry import pipeline_check

        check_tey2014 = pipeline_check("tey2014")
        assert check_tey2014 is not None  # the paper's pipeline checks its config
        rest = {k: v for k, v in config.items() if k != "identify"}
        return {**check_tey2014(rest), "identify": opts}
    return {**config, "identify": opts}


def run_identify_pipeline(config: dict[str, Any], run_dir: Path) -> dict[str, Any]:
    """Pipeline "identify": the job on the config's ``KCIdentification`` data, files into
    ``run_dir`` (``identified.toml``, ``report.md``, ``identify.json``, figures).
    ``identify.method = "tey2014"`` runs the paper's pipeline on the same targets."""
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    opts = _identify_table(config)
    if opts["method"] == "tey2014":
        from suspenv.registry import pipeline_function

        rest = {k: v for k, v in config.items() if k != "identify"}
        return pipeline_function("tey2014")(rest, run_dir)
    t0 = time.perf_counter()
    problem = _problem(config)
    progress = bool((config.get("run", {}) or {}).get("progress", False))
    plots = plots_wanted(config) and opts["figures"]
    result = run_identify(
        problem.measurement,
        problem.vehicle,
        opts,
        truth=problem.truth,
        progress=progress,
        seed=int(config.get("seed", 0)),
    )
    files = write_outputs(result, run_dir, figures=plots)

    s = summary(result)
    wall = time.perf_counter() - t0
    n_eval = int(result.model.stats["designs"])
    s.update(
        name=config.get("name"),
        seed=int(config.get("seed", 0)),
        strategy="cmaes+least_squares" if opts["global_evaluations"] else "least_squares",
        budget=int(opts["global_evaluations"]),
        n_evaluations=n_eval,
        n_ok=n_eval,
        n_feasible=n_eval,
        wall_time_s=wall,
        pipeline_wall_time_s=wall,
        quality_name="sum of squared noise-scaled residuals",
        best_quality=result.fit.cost,
        report="report.md",
        files=[str(f.relative_to(run_dir)) for f in files],
    )
    write_json(run_dir / "summary.json", s)
    return s
