"""KCIdentification: recover a McPherson axle's 49 parameters from K&C rig tests.

After Tey et al. 2014 (see ``docs/knc.md`` and the spec ``kc_identification.md``).

* Design space: the paper's 49 parameters (ADAMS/Car mm, left side; N/mm, N*mm/deg;
  N*m/rad; deg) with its ranges, widened where its own identified values fall
  outside them (documented per parameter). The model is left/right symmetric.
* Measured targets: the 40 objectives of a "test vehicle" = the reference vehicle
  (the paper's identified values) plus concealed effects: left/right tolerances,
  rubber-bushing hysteresis and sensor noise (``truth_seed``). Every test is a loop
  design -> bump -> rebound -> design; a loop becomes a target as the mean of its
  two branches' numbers at the static position (value and fitted gradient), which is
  what the paper did with its measured loops.
* Objectives (40, minimised): per-objective mismatch ``|simulated - measured|`` in
  the objective's unit (see :data:`suspenv.metrics.knc.OBJECTIVES`).
* Quality (the one scalar of the suite, ``compare``, run summaries): the RMS of the 40
  mismatches, each in standard errors of its measured number
  (:func:`noise_scaled_rms`, scales :attr:`KCIdentification.objective_scales` from
  :func:`objective_noise`); dimensionless, the same for any choice of units.
* No constraints. A design whose Newton iteration fails or whose bushings deflect
  beyond reason (a design that cannot carry its loads) is a failed evaluation with
  the reason.

Extra hooks for the study pipeline: ``initial_design()`` (the paper's initial
estimates), ``truth_design()`` (mean of the test vehicle's two sides),
``residuals(X)`` (signed mismatches), ``curves(x)`` and ``measured_curves()``; and
``write_report`` for optimisation runs. With ``measurements`` (measured loops of a real
axle, ``docs/knc.md`` "Measured K&C format", in place of the test car) the truth is
unknown (``truth_design`` is None); ``measurement`` holds the data as a
:class:`~suspenv.measurements.knc_file.KncMeasurement` in both cases (the test car with
the rig's declared noise). The options are the class's arguments.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core import DesignSpace, EvaluationBatch, Problem, compiled
from suspenv.core.errors import ValidationError
from suspenv.core.options import check_keywords, integer, number, text, texts
from suspenv.measurements.knc import DISPLAY
from suspenv.metrics import knc_kernel
from suspenv.metrics.knc import (
    FIT_HALF_WIDTH,
    OBJECTIVE_CHANNELS,
    OBJECTIVE_NAMES,
    OBJECTIVE_UNITS,
    OBJECTIVES,
    objectives,
)
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.effects import axle_effect
from suspenv.models.mcpherson.params import (
    build_axle,
    design_space,
    paper_initial_values,
)
from suspenv.models.mcpherson.solver import AxleSolver
from suspenv.models.mcpherson.truth import TruthVehicle
from suspenv.registry import report_function
from suspenv.rigs import knc
from suspenv.rigs.knc import TESTS, KCResult, run_tests
from suspenv.rigs.knc_truth import CONCEALED, car_measurement, concealed_car, measure_tests

#: channels shown by ``curves``: label with unit -> (rig channel, scale to that unit)
CURVE_CHANNELS = {
    f"{DISPLAY[c].words} [{DISPLAY[c].unit}]": (c, DISPLAY[c].scale)
    for c in ("toe", "camber", "caster", "tyre_fz", "wheel_centre_y")
}

#: the objectives as the compiled kernel reads them (:func:`.knc_kernel.objective_table`)
_TABLE = knc_kernel.objective_table(OBJECTIVES, TESTS)


def objective_noise(results: Mapping[str, KCResult], noise: Mapping[str, float]) -> np.ndarray:
    """Standard error (40,) of each objective measured from ``results``, in the
    objective's own unit (:data:`~suspenv.metrics.knc.OBJECTIVE_UNITS`).

    The rig's noise: every recorded sample of channel ``c`` (each wheel, each step of
    the loop) carries independent Gaussian noise of standard deviation ``noise[c]`` [SI,
    the channel's unit], as the test car's sensors
    (:func:`~suspenv.rigs.knc_truth.measure_car`) and a measured folder's ``[noise]``
    (or its estimate) declare. Propagated to first order through
    :func:`~suspenv.metrics.knc.objectives` itself (fits, branch and wheel means,
    abscissas that are channels too): ``se_j^2 = sum_k (noise_k * dF_j/dy_k)^2`` over
    the samples ``y_k`` of the fit window, each derivative a central difference with
    step ``noise_k`` (exact for the objectives that are linear in their samples). Only
    channels the objectives read count; correlations between objectives (value and
    gradient of one fit) are left out.
    """
    tests = list(results)
    st = {t: results[t].static_index for t in tests}
    rows: list[tuple[str, str, int, int, float]] = []  # test, channel, path index, wheel, h
    for t in tests:
        near = np.flatnonzero(np.abs(results[t].path - st[t]) <= FIT_HALF_WIDTH)
        for c in OBJECTIVE_CHANNELS:
            h = float(noise.get(c, 0.0))
            if h > 0:
                rows += [(t, c, int(i), w, h) for i in near for w in (0, 1)]
    n = 2 * len(rows)
    batch = {}
    for t in tests:
        r = results[t]
        ch = {c: np.repeat(r.channels[c][:1], n, axis=0) for c in OBJECTIVE_CHANNELS}
        batch[t] = KCResult(t, r.grid, r.path, ch, np.ones(n, bool), [""] * n)
    for k, (t, c, i, w, h) in enumerate(rows):
        batch[t].channels[c][2 * k, i, w] += h
        batch[t].channels[c][2 * k + 1, i, w] -= h
    F = objectives(batch)
    half_steps = 0.5 * (F[0::2] - F[1::2])  # noise_k * dF/dy_k, (samples, 40)
    se: np.ndarray = np.sqrt((half_steps**2).sum(axis=0))
    return se


def noise_scaled_rms(F: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """``sqrt(mean_j (F_j / s_j)^2)`` per row of mismatches F (n, m) [objective units]
    with scales s (m,) in the same units: dimensionless (1: every mismatch one standard
    error on average, root mean square)."""
    r = np.atleast_2d(F) / np.asarray(scales, dtype=float)
    out: np.ndarray = np.sqrt(np.mean(r * r, axis=1))
    return out


#: keys of an axle-effect table (``model_effects`` items)
EFFECT_KEYS = ("kind", "location", "params", "name")


def effect_from_dict(d: Mapping[str, Any], owner: str = "axle effect") -> Effect:
    """An axle effect from ``{"kind", "location", "params", "name"}`` (name optional).

    Rules: no other keys; ``kind`` and ``location`` strings; ``params`` a table of finite
    numbers (the effects library checks their names and ranges); ``name`` a string.
    """
    if not isinstance(d, Mapping):
        raise ValidationError(
            f"{owner} must be a table with 'kind', 'location' (and optional 'params', "
            f"'name'), but got {d!r}"
        )
    check_keywords(owner, d, EFFECT_KEYS, what="key")
    missing = [k for k in ("kind", "location") if k not in d]
    if missing:
        raise ValidationError(
            f"{owner}: an axle effect needs 'kind' and 'location', but {d} lacks {missing}"
        )
    params = d.get("params", {})
    if not isinstance(params, Mapping):
        raise ValidationError(f"{owner}: `params` must be a table of numbers, but got {params!r}")
    values = {str(k): number(owner, f"params.{k}", v) for k, v in params.items()}
    name = None if d.get("name") is None else text(owner, "name", d["name"])
    return axle_effect(
        text(owner, "kind", d["kind"]), text(owner, "location", d["location"]), name, **values
    )


def _model_effects(owner: str, tables: Sequence[Mapping[str, Any]] | None) -> tuple[Effect, ...]:
    """The model's effects from their tables (:func:`effect_from_dict`; None: none)."""
    if tables is not None and not isinstance(tables, list | tuple):
        raise ValidationError(
            f"{owner}: `model_effects` must be a list of effect tables, but got "
            f"model_effects={tables!r}"
        )
    return tuple(
        effect_from_dict(d, f"{owner}: model_effects[{i}]") for i, d in enumerate(tables or ())
    )


@lru_cache(maxsize=8)
def _measured(seed: int, concealed: tuple[str, ...], amplitude: float, steps: int):
    truth = concealed_car(seed, concealed)
    results = measure_tests(truth, TESTS, amplitude, steps)
    return truth, results, objectives(results)[0]


class KCIdentification(Problem):
    """Identify 49 McPherson parameters from the 40 K&C objectives of a concealed-effect car.

    Args (checked at construction):
        truth_seed: seed of the test vehicle's tolerances and sensor noise, integer >= 0.
        concealed: effects of the test vehicle, a list of any of ``("hysteresis",
            "tolerance", "noise")``; ``()`` makes the reference vehicle itself the target
            (exactly reachable).
        amplitude_mm: wheel-pad stroke of every test (+-, paper: 40 mm), ``0 < . <= 80``.
        steps: grid intervals over the stroke (paper: 30), an even integer >= 8.
        model_effects: effects of the *simulated* model (fixed, not design variables),
            each ``{"kind", "location", "params"}`` (optional ``"name"``) of an axle
            effect (:mod:`suspenv.models.mcpherson.effects`), e.g. to refit with the
            hysteresis a diagnosis has named; ``None`` is the paper's plain model.
        measurements: path of a measured-K&C folder (or its ``knc.toml``) holding the
            three travel tests; replaces the test car (``truth_seed`` and ``concealed``
            are then unused), and its amplitude and grid replace ``amplitude_mm`` and
            ``steps``. None: the built-in test car.
        vehicle: path of a vehicle file (``"reference"`` or None: the shipped reference
            vehicle): constants, bushing orientations and effects of the model, its
            design space (``[bounds]``) and, with ``measurements``, the start design.
    """

    name = "KCIdentification"
    description = (
        "Tey et al. 2014: 49 McPherson K&C parameters (hard points, bushings, ARB, "
        "alignment) from 40 rig objectives of a test car with hidden hysteresis/tolerances"
    )

    def __init__(
        self,
        truth_seed: int = 0,
        concealed: tuple[str, ...] | list[str] = CONCEALED,
        amplitude_mm: float = 40.0,
        steps: int = 30,
        model_effects: Sequence[Mapping[str, Any]] | None = None,
        measurements: str | None = None,
        vehicle: str | None = None,
    ):
        owner = self.name
        self.truth_seed = integer(owner, "truth_seed", truth_seed, lo=0)
        self.concealed = tuple(sorted(set(texts(owner, "concealed", concealed, CONCEALED))))
        amplitude = number(owner, "amplitude_mm", amplitude_mm, lo=0.0, hi=80.0, lo_open=True)
        self.amplitude = amplitude / 1e3  # m
        self.steps = integer(owner, "steps", steps, lo=8)
        if self.steps % 2:
            raise ValidationError(
                f"{owner}: `steps` must be even and >= 8, but got steps={steps!r}"
            )
        self.model_effects: tuple[Effect, ...] = _model_effects(owner, model_effects)
        from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, load_vehicle

        for key, val in (("measurements", measurements), ("vehicle", vehicle)):
            if val is not None and not isinstance(val, str | Path):
                raise ValidationError(
                    f"{owner}: `{key}` must be a path (text), but got {key}={val!r}"
                )
        self.measurements_path = None if measurements is None else str(measurements)
        self.vehicle_path = None if vehicle in (None, "reference") else str(vehicle)
        self.vehicle = load_vehicle(
            REFERENCE_FILE if self.vehicle_path is None else Path(self.vehicle_path)
        )
        self.space: DesignSpace = design_space() if vehicle is None else self.vehicle.space()
        self.objective_names = OBJECTIVE_NAMES
        self.objective_units = OBJECTIVE_UNITS
        self.constraint_names = ()
        self.truth: TruthVehicle | None = None
        self.measured: dict[str, KCResult]
        if self.measurements_path is None:
            targets = self._test_car_targets()
        else:
            targets = self._measured_targets(Path(self.measurements_path))
        self.targets: np.ndarray = targets.copy()

    def _test_car_targets(self) -> np.ndarray:
        """The objectives (40,) of the test car's loops (its truth, results and
        measurement set here)."""
        truth, results, targets = _measured(
            self.truth_seed, self.concealed, self.amplitude, self.steps
        )
        self.truth = truth
        self.measured = results
        if not truth.effects and not truth.noise and self._compiled_path():
            # loops the model itself makes (no effects, no noise): their objectives
            # by the candidates' own path, so that the truth reproduces them to the bit
            F, status = self._simulate_compiled(truth.axle())
            targets = targets if status[0] else F[0]
        self.measurement = car_measurement(results, self.truth_seed, self.concealed)
        return targets

    def _measured_targets(self, path: Path) -> np.ndarray:
        """The objectives (40,) of the measured loops in the file ``path`` (measurement,
        results, stroke [m] and steps set here from the file; the travel tests must
        share one stroke and grid)."""
        from suspenv.measurements.knc_file import load_measurement
        from suspenv.rigs.knc_measured import measured_results

        owner = self.name
        self.measurement = load_measurement(path, tests=TESTS)
        self.measured = {t: r for t, r in measured_results(self.measurement).items() if t in TESTS}
        first = self.measured[TESTS[0]]
        self.steps = int(first.grid.size - 1)
        self.amplitude = float(first.grid[-1])
        for t, r in self.measured.items():
            if r.grid.size - 1 != self.steps or not np.isclose(r.grid[-1], self.amplitude):
                raise ValidationError(
                    f"{owner}: the travel tests must share one stroke and grid, but "
                    f"{t!r} has +-{r.grid[-1] * 1e3:g} mm in {r.grid.size - 1} steps and "
                    f"{TESTS[0]!r} +-{self.amplitude * 1e3:g} mm in {self.steps} steps"
                )
        return objectives(self.measured)[0]

    # ----------------------------------------------------------------- physics
    #: candidates per internal chunk of the rig's numpy path in :meth:`simulate` (None:
    #: the whole batch at once). Its designs are split into equal chunks of at most this
    #: size. Every row of the rig batch is solved independently (per-row convergence and
    #: Jacobians), so chunking does not change the results; it bounds the peak memory
    #: (below 0.1 MB per candidate inside a chunk; docs/knc.md "Speed") while keeping
    #: most of the batching gain. The compiled path sweeps design by design in scratch
    #: of one design, so it takes the whole batch in one call.
    eval_chunk: int | None = 32
    #: a path-independent model solves every grid point once, both legs of the loop
    #: side by side, the return legs taking the states of their grid points
    #: (:func:`suspenv.rigs.knc.run_tests` ``reuse_revisits``); False: the reference
    #: path that solves every step of the loop one after the other (speed benchmark)
    reuse_revisits: bool = True
    #: the channels are kept at the objectives' fit window only (the grid points within
    #: :data:`~suspenv.metrics.knc.FIT_HALF_WIDTH` steps of the design position, all the
    #: objectives read), every step of the loop still solved and judged
    #: (:func:`suspenv.rigs.knc.run_tests` ``window``; the same objectives); None: the
    #: channels of every grid point (the speed benchmark's reference path)
    window: int | None = FIT_HALF_WIDTH

    def simulate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Simulated objectives (n, 40), ok (n,), messages for physical designs X (n, 49):
        the compiled sweep and objectives (:meth:`_simulate_compiled`) of the whole batch
        where they apply, the designs they flag (their rows of the axle already built) and
        every other case through the rig's results (:meth:`_simulate_rig`) in chunks of
        :attr:`eval_chunk` designs (bounded memory)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = X.shape[0]
        F = np.full((n, len(OBJECTIVE_NAMES)), np.nan)
        ok = np.ones(n, bool)
        msgs = [""] * n
        rows = np.arange(n)
        axle = self._axle(X)
        if self._compiled_path():
            F, status = self._simulate_compiled(axle)
            rows = np.flatnonzero(status)
        if rows.size:
            self._simulate_chunks(axle, rows, F, ok, msgs)
        bad = ok & ~np.isfinite(F).all(axis=1)
        for i in np.flatnonzero(bad):
            msgs[i] = "EvaluationError: an objective is not finite"
        ok &= ~bad
        F[~ok] = np.nan
        return F, ok, msgs

    def _simulate_chunks(
        self, axle: Any, rows: np.ndarray, F: np.ndarray, ok: np.ndarray, msgs: list[str]
    ) -> None:
        """The objectives, ok and messages of the design ``rows`` of ``axle`` into ``F``
        (n, 40), ``ok`` (n,) and ``msgs`` through the rig's results
        (:meth:`_simulate_rig`), in equal chunks of at most :attr:`eval_chunk` designs."""
        m = rows.size
        parts = 1 if self.eval_chunk is None else -(-m // max(1, int(self.eval_chunk)))
        edges = np.linspace(0, m, parts + 1).round().astype(int)  # equal chunks
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            if b > a:
                part = rows[a:b]
                F[part], ok[part], again = self._simulate_rig(axle.take(part))
                for row, msg in zip(part.tolist(), again, strict=True):
                    msgs[row] = msg

    def _compiled_path(self) -> bool:
        """The compiled sweep and objectives apply: the plain model on the two-leg loop
        with the channels at the fit window (the defaults) and the compiled sweep on."""
        return bool(
            knc.COMPILED_SWEEP
            and compiled.AVAILABLE
            and not self.model_effects
            and self.reuse_revisits
            and self.window == FIT_HALF_WIDTH
        )

    def _simulate_compiled(self, axle: Any) -> tuple[np.ndarray, np.ndarray]:
        """Objectives (m, 40) and the sweep's status (m,) (0: converged everywhere) of the
        designs of ``axle``: one compiled sweep of the three travel tests
        (:meth:`AxleSolver.two_leg_sweep`, the states kept at the fit window) and one
        compiled call for the objectives (:func:`.knc_kernel.objectives`); the same
        numbers as :meth:`_simulate_rig` to rounding."""
        solver = AxleSolver(axle)
        i0 = self.steps // 2
        kept = slice(i0 - FIT_HALF_WIDTH, i0 + FIT_HALF_WIDTH + 1)
        pad_off = self._pad_offsets
        st, status = solver.two_leg_sweep(pad_off, None, None, kept)
        pads = solver.pad_static + pad_off[:, kept, None, :]  # (T, Q, m, 2) [m]
        F = np.empty((solver.n, len(OBJECTIVE_NAMES)))
        knc_kernel.objectives(
            st.r, st.R, pads, *(np.ascontiguousarray(solver.s0), solver.Rw, solver.kt),
            np.ascontiguousarray(solver.kn_pts[:, :, 0]), _TABLE, F,
        )  # fmt: skip
        return F, status

    @cached_property
    def _pad_offsets(self) -> np.ndarray:
        """The pad offsets (T, G, 2) [m] of the travel tests on the problem's grid."""
        grid = knc.stroke_grid(self.amplitude, self.steps)
        return np.stack([knc.pad_offsets(t, grid) for t in TESTS])

    def _simulate_rig(self, axle: Any) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Objectives (m, 40), ok (m,) and messages of the designs of ``axle`` from the
        rig's results (:func:`~suspenv.rigs.knc.run_tests`, then
        :func:`~suspenv.metrics.knc.objectives`)."""
        results = run_tests(
            axle,
            TESTS,
            self.amplitude,
            self.steps,
            self.model_effects,
            reuse_revisits=self.reuse_revisits,
            channels=OBJECTIVE_CHANNELS,  # only those the objectives read (memory)
            window=self.window,  # only where the objectives read them (memory, time)
        )
        m = results[TESTS[0]].ok.shape[0]
        ok = np.ones(m, bool)
        msgs = [""] * m
        for t in TESTS:
            r = results[t]
            for i in np.flatnonzero(~r.ok & ok):
                msgs[i] = f"{t} travel: {r.messages[i]}"
            ok &= r.ok
        F = np.full((m, len(OBJECTIVE_NAMES)), np.nan)
        if ok.any():
            F[ok] = objectives(results)[ok]
        return F, ok, msgs

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        F, ok, msgs = self.simulate(X)
        n = X.shape[0]
        return EvaluationBatch(
            np.abs(F - self.targets), np.zeros((n, 0)), ok, msgs, {"simulated": F}
        )

    # ------------------------------------------------------------- study hooks
    def residuals(self, X: np.ndarray) -> np.ndarray:
        """Signed mismatches ``simulated - measured`` (n, 40); NaN rows for failures."""
        return self.simulate(self.space.check_batch(X))[0] - self.targets

    def _axle(self, X: np.ndarray) -> Any:
        """Batched axle of designs X (n, 49): symmetric, with the vehicle file's constants
        and bushing orientations (the reference vehicle's by default)."""
        v = self.vehicle
        return build_axle(X, None, v.constants, v.orientation or None)

    def initial_design(self) -> np.ndarray:
        """The paper's initial model: hard points at the centres of its ranges, every
        bushing stiffness 500, anti-roll bar 300, camber and toe 0; with measured data,
        the vehicle file's design (mean of its two sides)."""
        if self.measurements_path is not None:
            return 0.5 * (self.vehicle.left + self.vehicle.right)
        return self.space.from_dict(paper_initial_values())

    @property
    def truth_design(self) -> Any:
        """The hook ``truth_design() -> (49,)``: the symmetric design nearest to the test
        vehicle (mean of its two sides); None with measured data (the truth is unknown)."""
        return None if self.truth is None else self._truth_design

    def _truth_design(self) -> np.ndarray:
        assert self.truth is not None  # invariant: the hook exists only with a truth
        return self.truth.mean_design.copy()

    def curves(self, x: np.ndarray) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
        """Left-wheel loops of one design: {test: {channel: (pad stroke [mm], value)}}."""
        X = self.space.check_batch(x)[:1]
        return _curves(
            run_tests(self._axle(X), TESTS, self.amplitude, self.steps, self.model_effects)
        )

    def measured_curves(self) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
        """The test vehicle's measured loops, same layout as :meth:`curves`."""
        return _curves(self.measured)

    #: the suite's, compare's and the run summaries' scalar (40 objectives are too many
    #: for a hypervolume): :func:`noise_scaled_rms` of the mismatches
    quality_name = "RMS mismatch in standard errors"

    @cached_property
    def objective_scales(self) -> np.ndarray:
        """Standard error (40,) of each measured objective, in its unit
        (:data:`~suspenv.metrics.knc.OBJECTIVE_UNITS`): :func:`objective_noise` of the
        measured loops under the measurement's channel noise (the test car: the rig's
        declared :data:`~suspenv.models.mcpherson.truth.CHANNEL_NOISE`, also when no noise
        is concealed; a measured folder: its ``[noise]`` or the estimate)."""
        s = objective_noise(self.measured, self.measurement.noise)
        bad = [n for n, v in zip(OBJECTIVE_NAMES, s, strict=True) if not (v > 0 and np.isfinite(v))]
        if bad:
            raise ValidationError(
                f"{self.name}: every objective's standard error must be > 0 and finite (the "
                f"channels it reads need a noise > 0), but it is not for {bad}"
            )
        return s

    def quality(self, F: np.ndarray) -> np.ndarray:
        """RMS over the 40 mismatches F (n, 40) of ``F_j / objective_scales[j]`` per row
        (:func:`noise_scaled_rms`; dimensionless, lower is better)."""
        return noise_scaled_rms(F, self.objective_scales)

    def write_report(self, run_dir: Path, archive: Any) -> list[Path]:
        """``kc_report.md`` (targets vs initial vs best model per objective) and
        ``kc_curves.png`` (measured loops vs the best design's curves), written by
        :func:`suspenv.reports.kc_identification.write_kc_report`."""
        return report_function("KCIdentification")(self, Path(run_dir), archive)

    def config(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "truth_seed": self.truth_seed,
            "concealed": list(self.concealed),
            "amplitude_mm": self.amplitude * 1e3,
            "steps": self.steps,
            "model_effects": [e.to_dict() for e in self.model_effects] or None,
        }
        for key, val in (("measurements", self.measurements_path), ("vehicle", self.vehicle_path)):
            if val is not None:  # only when given: the test car's config is unchanged
                out[key] = val
        return out


def _curves(results: dict[str, KCResult]) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
    out: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
    for test, r in results.items():
        s = r.grid[r.path] * 1e3
        out[f"{test} travel"] = {
            label: (s.copy(), r.channels[ch][0, :, 0] * scale)
            for label, (ch, scale) in CURVE_CHANNELS.items()
        }
    return out
