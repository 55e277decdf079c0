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
* No constraints. A design whose Newton iteration fails or whose bushings deflect
  beyond reason (a design that cannot carry its loads) is a failed evaluation with
  the reason.

Extra hooks for the study pipeline: ``initial_design()`` (the paper's initial
estimates), ``truth_design()`` (mean of the test vehicle's two sides),
``residuals(X)`` (signed mismatches), ``curves(x)`` and ``measured_curves()``; and
``write_report`` for optimisation runs. ``model_effects`` gives the simulated model
fixed optional physics (e.g. to refit with a hysteresis a diagnosis has named):
effects-library elements at bushings or the strut
(:mod:`suspenv.models.mcpherson.effects`), as dicts ``{"kind", "location", "params"}``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core import DesignSpace, EvaluationBatch, Problem
from suspenv.core.errors import ValidationError
from suspenv.core.options import check_keywords, integer, number, text, texts
from suspenv.metrics.knc import OBJECTIVE_NAMES, OBJECTIVE_UNITS, objectives
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.effects import axle_effect
from suspenv.models.mcpherson.params import (
    BUSHINGS,
    HARD_POINTS,
    PAPER_RANGES,
    build_axle,
    design_space,
)
from suspenv.models.mcpherson.truth import TruthVehicle, truth_vehicle
from suspenv.registry import report_function
from suspenv.rigs.knc import TESTS, KCResult, run_tests

#: channels shown by ``curves``: label with unit -> (rig channel, scale to that unit)
CURVE_CHANNELS = {
    "toe [deg]": ("toe", np.rad2deg(1.0)),
    "camber [deg]": ("camber", np.rad2deg(1.0)),
    "caster [deg]": ("caster", np.rad2deg(1.0)),
    "tyre force [N]": ("tyre_fz", 1.0),
    "wheel centre lateral [mm]": ("wheel_centre_y", 1e3),
}

CONCEALED = ("hysteresis", "tolerance", "noise")


def measure(truth: TruthVehicle, amplitude: float = 0.040, steps: int = 30) -> dict[str, KCResult]:
    """Run the three rig tests on the truth vehicle and add its sensor noise (seeded)."""
    results = run_tests(truth.axle(), amplitude=amplitude, steps=steps, effects=truth.effects)
    rng = np.random.default_rng(10_000 + truth.seed)
    for test in sorted(results):
        res = results[test]
        if not res.ok.all():
            raise ValidationError(f"the truth vehicle fails the {test} test: {res.messages[0]}")
        for name in sorted(truth.noise):
            ch = res.channels[name]
            res.channels[name] = ch + rng.normal(0.0, truth.noise[name], ch.shape)
    return results


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


@lru_cache(maxsize=8)
def _measured(seed: int, concealed: tuple[str, ...], amplitude: float, steps: int):
    truth = truth_vehicle(
        seed,
        hysteresis="hysteresis" in concealed,
        tolerance="tolerance" in concealed,
        noise="noise" in concealed,
    )
    results = measure(truth, amplitude, steps)
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
        if model_effects is not None and not isinstance(model_effects, list | tuple):
            raise ValidationError(
                f"{owner}: `model_effects` must be a list of effect tables, but got "
                f"model_effects={model_effects!r}"
            )
        self.model_effects: tuple[Effect, ...] = tuple(
            effect_from_dict(d, f"{owner}: model_effects[{i}]")
            for i, d in enumerate(model_effects or ())
        )
        self.space: DesignSpace = design_space()
        self.objective_names = OBJECTIVE_NAMES
        self.objective_units = OBJECTIVE_UNITS
        self.constraint_names = ()
        truth, results, targets = _measured(
            self.truth_seed, self.concealed, self.amplitude, self.steps
        )
        self.truth: TruthVehicle = truth
        self.measured: dict[str, KCResult] = results
        self.targets: np.ndarray = targets.copy()

    # ----------------------------------------------------------------- physics
    #: candidates per internal chunk of :meth:`simulate` (None: the whole batch at once).
    #: A batch is split into equal chunks of at most this size. Every row of the rig
    #: batch is solved independently (per-row convergence and Jacobians), so chunking
    #: does not change the results; it bounds the peak memory (about 0.5 MB per
    #: candidate inside a chunk) while keeping most of the batching gain.
    eval_chunk: int | None = 64
    #: reuse the first visit's state at revisited grid points of a path-independent
    #: model (:func:`suspenv.rigs.knc.run_tests` ``reuse_revisits``); False: the
    #: reference path that solves every step one after the other (speed benchmark)
    reuse_revisits: bool = True

    def simulate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Simulated objectives (n, 40), ok (n,), messages for physical designs X (n, 49).

        Evaluated in chunks of :attr:`eval_chunk` candidates (bounded memory)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = X.shape[0]
        parts = 1 if self.eval_chunk is None else -(-n // max(1, int(self.eval_chunk)))
        edges = np.linspace(0, n, parts + 1).round().astype(int)  # equal chunks
        F = np.full((n, len(OBJECTIVE_NAMES)), np.nan)
        ok = np.ones(n, bool)
        msgs = [""] * n
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            F[a:b], ok[a:b], msgs[a:b] = self._simulate_chunk(X[a:b])
        return F, ok, msgs

    def _simulate_chunk(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """:meth:`simulate` of one chunk of designs X (m, 49)."""
        results = run_tests(
            build_axle(X),
            TESTS,
            self.amplitude,
            self.steps,
            self.model_effects,
            reuse_revisits=self.reuse_revisits,
        )
        ok = np.ones(X.shape[0], bool)
        msgs = [""] * X.shape[0]
        for t in TESTS:
            r = results[t]
            for i in np.flatnonzero(~r.ok & ok):
                msgs[i] = f"{t} travel: {r.messages[i]}"
            ok &= r.ok
        F = np.full((X.shape[0], len(OBJECTIVE_NAMES)), np.nan)
        if ok.any():
            F_all = objectives(results)
            F[ok] = F_all[ok]
        bad = ok & ~np.isfinite(F).all(axis=1)
        for i in np.flatnonzero(bad):
            msgs[i] = "EvaluationError: an objective is not finite"
        ok &= ~bad
        F[~ok] = np.nan
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

    def initial_design(self) -> np.ndarray:
        """The paper's initial model: hard points at the centres of its ranges, every
        bushing stiffness 500, anti-roll bar 300, camber and toe 0."""
        values: dict[str, float] = {}
        for hp in HARD_POINTS:
            for axis, (lo, hi) in zip("xyz", PAPER_RANGES[hp], strict=True):
                values[f"{hp}_{axis}"] = 0.5 * (lo + hi)
        for b, comps in BUSHINGS.items():
            for c in comps:
                values[f"{b}_{c}"] = 500.0
        values.update(arb_torsion=300.0, static_camber=0.0, static_toe=0.0)
        return self.space.from_dict(values)

    def truth_design(self) -> np.ndarray:
        """The symmetric design nearest to the test vehicle (mean of its two sides)."""
        return self.truth.mean_design.copy()

    def curves(self, x: np.ndarray) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
        """Left-wheel loops of one design: {test: {channel: (pad stroke [mm], value)}}."""
        X = self.space.check_batch(x)[:1]
        return _curves(
            run_tests(build_axle(X), TESTS, self.amplitude, self.steps, self.model_effects)
        )

    def measured_curves(self) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
        """The test vehicle's measured loops, same layout as :meth:`curves`."""
        return _curves(self.measured)

    def best_index(self, F: np.ndarray, ok: np.ndarray) -> int | None:
        """Row of the best valid design: least sum of mismatches, each divided by its
        spread over the valid rows (a fixed-scale stand-in for the rank-sum)."""
        valid = np.asarray(ok, bool) & np.isfinite(F).all(axis=1)
        if not valid.any():
            return None
        spread = np.ptp(F[valid], axis=0)
        total = (F / np.where(spread > 0, spread, 1.0)).sum(axis=1)
        return int(np.flatnonzero(valid)[np.argmin(total[valid])])

    def write_report(self, run_dir: Path, archive: Any) -> list[Path]:
        """``kc_report.md`` (targets vs initial vs best model per objective) and
        ``kc_curves.png`` (measured loops vs the best design's curves), written by
        :func:`suspenv.reports.kc_identification.write_kc_report`."""
        return report_function("KCIdentification")(self, Path(run_dir), archive)

    def config(self) -> dict[str, Any]:
        return {
            "truth_seed": self.truth_seed,
            "concealed": list(self.concealed),
            "amplitude_mm": self.amplitude * 1e3,
            "steps": self.steps,
            "model_effects": [e.to_dict() for e in self.model_effects] or None,
        }


def _curves(results: dict[str, KCResult]) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
    out: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
    for test, r in results.items():
        s = r.grid[r.path] * 1e3
        out[f"{test} travel"] = {
            label: (s.copy(), r.channels[ch][0, :, 0] * scale)
            for label, (ch, scale) in CURVE_CHANNELS.items()
        }
    return out
