"""Minibus speed: time per candidate of a full MinibusRideHandling evaluation.

A full evaluation is what the problem does for every candidate: both load cases of the
ride objectives (the exact spectral integral, class B, 80 km/h), the steady-state
circular test, the slalom and the step steer, then the 5 objectives and the
constraints. Measured in the same run, on the same random designs of the study's box:

- the default problem (``handling="standard"``: the step steer's yaw response time and
  the slalom's steering-wheel angle and roll amplitudes from the vehicle linearised at
  the manoeuvres' lateral acceleration, one quasi-steady sweep; the steady circle's
  limit searched on a tabulated axle capacity, many candidates per pass), batched (500,
  the study's NSGA-II population) and one design at a time;
- the study's handling objectives (``handling="study"``: the closed-loop nonlinear
  time-domain slalom), batched and one at a time;
- the previous default: the same evaluation with the spectral ride objectives by the
  modal expansion of the whole 14-state ride model (``ride_spectral(...,
  split=False)``, the algorithm before the default split the symmetric model into its
  decoupled symmetric and antisymmetric halves; :class:`PreviousDefault`), batched and
  one at a time;
- the baseline, the code before the handling changes: the time-domain slalom and the
  steady circle's bisection on the grid-search axle capacity, with the previous
  default's ride (:func:`baseline_measures`, kept here for the timing), batched and one
  at a time;
- the parts of the default evaluation (ride, handling parameters, steady circle, linear
  slalom) and the previous default's ride, batched and one at a time.

Targets: <= 5 ms per call one design at a time and <= 1 ms per design batched (issue
17). suspenv limits BLAS to one thread, so the process's CPU time is one core's time;
it is the reported figure (best of the repeats for batches, median of the single
calls), with the wall time beside it (which a loaded machine inflates). The
evaluations are timed interleaved (each batch repeat, and each design one at a time,
by all of them in turn), so a load that changes during the run weighs on all alike.

Run: ``python -m benchmarks.minibus_speed [--quick]``; writes
``docs/benchmarks/minibus_speed.json``.
"""

from __future__ import annotations

import argparse
import functools
import os
import statistics
import sys
from collections.abc import Callable
from typing import Any

import numpy as np
from tqdm import tqdm

from benchmarks.common import BatchTiming, wall_and_cpu, write_result
from suspenv.metrics.handling import slalom, slalom_linear
from suspenv.metrics.ride import ride_objectives_all, ride_spectral
from suspenv.models.minibus.handling_model import HandlingParams, handling_parameters
from suspenv.models.minibus.vehicle import LOAD_CASES
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.rigs.handling import (
    steady_circle,
    steady_circle_bisection,
)

TARGET_SINGLE_MS = 5.0
TARGET_BATCHED_MS = 1.0
STUDY_EVALUATIONS = 30_000


def full_model_ride(
    X: np.ndarray, problem: MinibusRideHandling
) -> dict[str, dict[str, np.ndarray]]:
    """The spectral ride objectives of both load cases by the modal expansion of the
    whole ride model (the previous algorithm), shaped as :func:`ride_objectives_all`
    returns them (m/s^2)."""
    X = np.atleast_2d(X)
    n = X.shape[0]
    sp = ride_spectral(X, LOAD_CASES, problem.road, problem.vehicle, split=False)
    keys = ("aw_front", "aw_rear", "rms_front", "rms_rear", "ok")
    return {lc: {k: sp[k][i * n : (i + 1) * n] for k in keys} for i, lc in enumerate(LOAD_CASES)}


class PreviousDefault(MinibusRideHandling):
    """The default problem with the previous spectral ride algorithm (:func:`full_model_ride`);
    the same numbers to round-off (tests/test_ride_spectral.py)."""

    def _ride(self, X: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        return full_model_ride(X, self)


def baseline_measures(problem: MinibusRideHandling, X: np.ndarray) -> np.ndarray:
    """The evaluation before the handling changes, for timing: spectral ride (the previous
    algorithm, :func:`full_model_ride`), bisection steady circle, time-domain slalom;
    returns the five objectives (n, 5)."""
    X = np.atleast_2d(X)
    n = X.shape[0]
    ride = full_model_ride(X, problem)
    P = HandlingParams.stack([handling_parameters(X, lc, problem.vehicle) for lc in LOAD_CASES])
    ay = steady_circle_bisection(P, problem.circle)
    sl = slalom(P, problem.slalom_config)
    w = problem.load_weight

    def comb(v: np.ndarray) -> np.ndarray:
        return v[:n] + w * v[n:]

    return np.column_stack(
        [
            ride["no_load"]["aw_front"] + w * ride["full_load"]["aw_front"],
            ride["no_load"]["aw_rear"] + w * ride["full_load"]["aw_rear"],
            -comb(ay),
            np.degrees(comb(sl.yaw_rate_amplitude)),
            np.degrees(comb(sl.roll_amplitude)),
        ]
    )


class _Baseline:
    """``evaluate`` of :func:`baseline_measures`, shaped for :func:`time_batch_vs_single`."""

    def __init__(self, problem: MinibusRideHandling):
        self.problem = problem

    def evaluate(self, X: np.ndarray) -> Any:
        F = baseline_measures(self.problem, X)

        class _Batch:
            ok = np.isfinite(F).all(axis=1)

        return _Batch()


def _interleaved(
    evaluators: list[Any], X: np.ndarray, repeats: int, singles: list[int]
) -> list[BatchTiming]:
    """:func:`time_batch_vs_single` for several evaluators, their measurements
    interleaved (batch repeats in turn; design i one at a time by each in turn), so a
    load that changes during the run weighs on all of them alike."""
    n = len(X)
    cpu: list[list[float]] = [[] for _ in evaluators]
    wall: list[list[float]] = [[] for _ in evaluators]
    valid = [0] * len(evaluators)
    for _ in tqdm(range(repeats), desc=f"batches of {n}", file=sys.stderr):
        for j, ev in enumerate(evaluators):
            out: dict[str, Any] = {}
            w, c = wall_and_cpu(lambda ev=ev, out=out: out.update(b=ev.evaluate(X)))  # type: ignore[misc]
            cpu[j].append(c)
            wall[j].append(w)
            valid[j] = int(np.sum(out["b"].ok))
    s_cpu: list[list[float]] = [[] for _ in evaluators]
    s_wall: list[list[float]] = [[] for _ in evaluators]
    for i in tqdm(range(max(singles)), desc="one at a time", file=sys.stderr):
        for j, ev in enumerate(evaluators):
            if i < singles[j]:
                w, c = wall_and_cpu(functools.partial(ev.evaluate, X[i : i + 1]))
                s_cpu[j].append(c)
                s_wall[j].append(w)
    return [
        BatchTiming(
            batch=n,
            repeats=repeats,
            singles=singles[j],
            batched_cpu_ms=1e3 * min(cpu[j]) / n,
            batched_wall_ms=1e3 * min(wall[j]) / n,
            single_cpu_ms=1e3 * statistics.median(s_cpu[j]),
            single_wall_ms=1e3 * statistics.median(s_wall[j]),
            valid=valid[j],
        )
        for j in range(len(evaluators))
    ]


class _Part:
    """``evaluate`` of one part of the evaluation, for :func:`_interleaved`."""

    def __init__(self, fn: Callable[[np.ndarray], Any]):
        self.fn = fn

    def evaluate(self, X: np.ndarray) -> Any:
        self.fn(X)

        class _Batch:
            ok = np.ones(len(X), dtype=bool)

        return _Batch()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    parser.add_argument("--batch", type=int, default=500, help="designs per batch")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else 3
    n_single = 5 if args.quick else 20
    n_single_slow = 3 if args.quick else 6

    problem = MinibusRideHandling()
    previous = PreviousDefault()
    study = MinibusRideHandling(handling="study")
    rng = np.random.default_rng(0)
    X = problem.space.to_physical(rng.random((args.batch, problem.space.dim)))
    problem.evaluate(X[:2])  # warm-up: imports, cached grids and tables
    previous.evaluate(X[:2])

    # parts of the default evaluation (CPU ms per design, batched and one at a time)
    def params(Z: np.ndarray) -> HandlingParams:
        return HandlingParams.stack([handling_parameters(Z, lc) for lc in LOAD_CASES])

    parts: dict[str, Callable[[np.ndarray], Any]] = {
        "ride, spectral (both loads)": lambda Z: ride_objectives_all(
            Z, LOAD_CASES, problem.road, dtype=np.float64, method="spectral"
        ),
        "ride, spectral, previous algorithm (full model, both loads)": lambda Z: full_model_ride(
            Z, problem
        ),
        "handling parameters (both loads)": params,
        "steady circle (both loads, with parameters)": lambda Z: steady_circle(
            params(Z), problem.circle
        ),
        "slalom at the course's a_y (both loads, with parameters)": lambda Z: slalom_linear(
            params(Z), problem.slalom_config
        ),
    }
    timings = _interleaved(
        [problem, previous, study, _Baseline(problem), *(_Part(fn) for fn in parts.values())],
        X,
        repeat,
        [n_single, n_single, n_single_slow, n_single_slow, *([n_single] * len(parts))],
    )
    t_new, t_prev, t_study, t_base = timings[:4]
    part_rows: list[dict[str, Any]] = []
    single_ms: list[float] = []
    for name, t in zip(parts, timings[4:], strict=True):
        single_ms.append(t.single_cpu_ms)
        part_rows.append(
            {
                "mode": f"  part: {name}",
                "cpu_ms_per_candidate": t.batched_cpu_ms,
                "cpu_ms_per_call_single": t.single_cpu_ms,
                "wall_ms_per_candidate": t.batched_wall_ms,
                "repeats": repeat,
            }
        )

    rows = [
        *t_new.rows(
            f"default (handling='standard'), batch of {args.batch}",
            "default (handling='standard'), one at a time",
        ),
        *part_rows,
        *t_prev.rows(
            f"previous default (full-model spectral ride), batch of {args.batch}",
            "previous default (full-model spectral ride), one at a time",
        ),
        *t_study.rows(
            f"study's handling (handling='study', time-domain slalom), batch of {args.batch}",
            "study's handling (handling='study'), one at a time",
        ),
        *t_base.rows(
            f"baseline (time-domain slalom, bisection circle, previous ride), "
            f"batch of {args.batch}",
            "baseline (before), one at a time",
        ),
    ]
    summary = {
        "batch": args.batch,
        "valid_candidates": t_new.valid,
        "ms_per_candidate_batched": t_new.batched_cpu_ms,
        "ms_per_call_single": t_new.single_cpu_ms,
        "wall_ms_per_candidate_batched": t_new.batched_wall_ms,
        "batching_gain": t_new.gain,
        "previous_default_ms_per_candidate_batched": t_prev.batched_cpu_ms,
        "previous_default_ms_per_call_single": t_prev.single_cpu_ms,
        "speedup_batched_vs_previous_default": t_prev.batched_cpu_ms / t_new.batched_cpu_ms,
        "speedup_single_vs_previous_default": t_prev.single_cpu_ms / t_new.single_cpu_ms,
        "ride_ms_per_candidate_batched": part_rows[0]["cpu_ms_per_candidate"],
        "ride_ms_per_call_single": single_ms[0],
        "previous_ride_ms_per_candidate_batched": part_rows[1]["cpu_ms_per_candidate"],
        "previous_ride_ms_per_call_single": single_ms[1],
        "study_handling_ms_per_candidate_batched": t_study.batched_cpu_ms,
        "study_handling_ms_per_call_single": t_study.single_cpu_ms,
        "baseline_ms_per_candidate_batched": t_base.batched_cpu_ms,
        "baseline_ms_per_call_single": t_base.single_cpu_ms,
        "speedup_single_vs_baseline": t_base.single_cpu_ms / t_new.single_cpu_ms,
        "speedup_batched_vs_baseline": t_base.batched_cpu_ms / t_new.batched_cpu_ms,
        "ride_share_of_single_call": single_ms[0] / t_new.single_cpu_ms,
        "target_single_ms": TARGET_SINGLE_MS,
        "target_batched_ms": TARGET_BATCHED_MS,
        "meets_single_target": bool(t_new.single_cpu_ms <= TARGET_SINGLE_MS),
        "meets_batched_target": bool(t_new.batched_cpu_ms <= TARGET_BATCHED_MS),
        "study_30000_evaluations_cpu_s_estimate": STUDY_EVALUATIONS * t_new.batched_cpu_ms / 1e3,
        "load_average_1min": os.getloadavg()[0],
    }
    cmd = "python -m benchmarks.minibus_speed" + (" --quick" if args.quick else "")
    write_result("minibus_speed", rows, summary, cmd, args.output_dir)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
