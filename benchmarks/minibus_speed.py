"""Minibus speed: time per candidate of a full MinibusRideHandling evaluation.

A full evaluation is what the problem does for every candidate: both load cases of the
ride objectives (the exact spectral integral, class B, 80 km/h), the steady-state
circular test, the slalom and the step steer, then the 5 objectives and the
constraints. Measured in the same run, on the same random designs of the study's box:

- the default problem (``handling="standard"``: the step steer's yaw response time and
  the slalom's steering-wheel angle and roll amplitudes from the vehicle linearised at
  the manoeuvres' lateral acceleration, one quasi-steady sweep; the steady circle's
  limit searched on a tabulated axle capacity, compiled row by row), batched (500,
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
- the default problem with the handling measures' iterative parts as numpy passes
  over the batch (the quasi-steady sweep with its slip-angle solve, the axle capacity,
  the yaw step-time and bandwidth searches; :func:`numpy_loops`, the form before the
  compiled loops of :mod:`suspenv.models.minibus.handling_kernel`), batched and one at
  a time;
- the parts of the default evaluation (ride, handling parameters, steady circle, linear
  slalom, the default set's handling measures) and the previous default's ride, batched
  and one at a time.

Targets: <= 1 ms per design batched; one design at a time <= 5 ms per call (issue 43)
and <= 1 ms (issue 44). suspenv limits BLAS to one thread, so the process's CPU time is
one core's time; it is the reported figure (best of the repeats for batches, median of
the single calls), with the wall time beside it (which a loaded machine inflates). The
evaluations are timed interleaved (each batch repeat, and each design one at a time,
by all of them in turn), so a load that changes during the run weighs on all alike.

Run: ``python -m benchmarks.minibus_speed [--quick]``; writes
``docs/benchmarks/minibus_speed.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import os
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from tqdm import tqdm

from benchmarks.common import BatchTiming, wall_and_cpu, write_result
from suspenv.core import compiled
from suspenv.metrics.ride import ride_spectral
from suspenv.models.minibus import handling_kernel, spectral_kernel
from suspenv.models.minibus.handling_model import HandlingParams, handling_parameters, wheel_loads
from suspenv.models.minibus.vehicle import LOAD_CASES
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.problems.minibus_ride import ride_objectives_all
from suspenv.rigs.handling import (
    SteadyCircleConfig,
    axle_capacity,
    slalom,
    slalom_linear,
    steady_circle,
)

TARGET_SINGLE_MS = 5.0
TARGET_SINGLE_COMPILED_MS = 1.0
TARGET_BATCHED_MS = 1.0
STUDY_EVALUATIONS = 30_000


def _axle_force(
    alpha: np.ndarray, d: np.ndarray, b: np.ndarray, e: np.ndarray, c: float
) -> np.ndarray:
    """Force (N) of the axles' two tyres (factors (2, m)) at slip angles ``alpha`` (..., m)."""
    out = []
    for w in range(2):
        ba = b[w] * alpha
        out.append(d[w] * np.sin(c * np.arctan(ba - e[w] * (ba - np.arctan(ba)))))
    return out[0] + out[1]


def numpy_capacity_loop(
    d: np.ndarray, b: np.ndarray, e: np.ndarray, c: float, grid: np.ndarray, out: np.ndarray
) -> None:
    """:func:`handling_kernel.capacity_loop` as numpy passes over the axles."""
    f = _axle_force(grid[:, None], d, b, e, c)  # (G, m)
    i = np.clip(np.argmax(f, axis=0), 1, grid.size - 2)
    cols = np.arange(f.shape[1])
    f0, f1, f2 = f[i - 1, cols], f[i, cols], f[i + 1, cols]
    denom = f0 - 2.0 * f1 + f2
    shift = np.where(denom < 0, 0.5 * (f0 - f2) / np.where(denom < 0, denom, -1.0), 0.0)
    a_peak = grid[i] + np.clip(shift, -1.0, 1.0) * (grid[1] - grid[0])
    out[0] = np.maximum(np.maximum(_axle_force(a_peak, d, b, e, c), f1), 0.0)
    out[1] = a_peak


def numpy_slip_loop(
    d: np.ndarray,
    b: np.ndarray,
    e: np.ndarray,
    c: float,
    grid: np.ndarray,
    force: np.ndarray,
    passes: int,
    out: np.ndarray,
) -> None:
    """The slip solve of :func:`handling_kernel.sweep_loop` as numpy passes: Illinois
    regula falsi on ``[0, peak slip]`` of the capacity search (the bracket before the
    compiled loop); ``out`` (2, m) = (slip angle rad, 1.0 where the axle can)."""
    cap = np.empty((2, force.size))
    numpy_capacity_loop(d, b, e, c, grid, cap)
    lo, hi = np.zeros_like(force), cap[1].copy()
    r_lo, r_hi = -force, _axle_force(hi, d, b, e, c) - force
    side = np.zeros(force.shape, dtype=np.int8)
    for _ in range(passes):
        span = r_hi - r_lo
        mid = np.where(span > 0, (lo * r_hi - hi * r_lo) / np.where(span > 0, span, 1.0), hi)
        r_mid = _axle_force(mid, d, b, e, c) - force
        below = r_mid < 0
        r_hi = np.where(below & (side == -1), 0.5 * r_hi, r_hi)
        r_lo = np.where(~below & (side == 1), 0.5 * r_lo, r_lo)
        lo, r_lo = np.where(below, mid, lo), np.where(below, r_mid, r_lo)
        hi, r_hi = np.where(below, hi, mid), np.where(below, r_hi, r_mid)
        side = np.where(below, -1, 1).astype(np.int8)
    out[0] = np.where(np.abs(r_lo) < np.abs(r_hi), lo, hi)
    out[1] = cap[0] >= force


def numpy_sweep_loop(
    rows: np.ndarray,
    ay: np.ndarray,
    k: np.ndarray,
    grid: np.ndarray,
    radius: float,
    passes: int,
    out: np.ndarray,
) -> None:
    """:func:`handling_kernel.sweep_loop` as numpy passes over all states at once (the
    slip solve by :func:`numpy_slip_loop`)."""
    # the plain helpers (a loop compiled at its first call swaps in numba's)
    transfer: Any = getattr(handling_kernel.axle_transfer, "py_func", handling_kernel.axle_transfer)
    factors: Any = getattr(handling_kernel.tyre_factors, "py_func", handling_kernel.tyre_factors)
    r = rows.T[:, None, :]  # (17, 1, n) against the accelerations (N, 1)
    acc = ay[:, None]
    phi = r[0] * acc
    fl, fr, rl, rr = transfer(
        (r[1] * phi + r[3] * acc) / r[5], (r[2] * phi + r[4] * acc) / r[6], r[7], r[8], r[5], r[6]
    )
    fyf, fyr = r[9] * acc * r[11] / r[12], r[9] * acc * r[10] / r[12]
    d, b, e = (f.reshape(2, -1) for f in factors(np.stack([[fl, rl], [fr, rr]]), k))
    slip = np.empty((2, d.shape[1]))
    numpy_slip_loop(d, b, e, float(k[1]), grid, np.stack([fyf, fyr]).ravel(), passes, slip)
    (af, ar), (can_f, can_r) = slip.reshape(2, 2, *fyf.shape)
    steer = r[12] / radius + af - ar - r[13] * phi - r[14] * fyf + r[15] * phi + r[16] * fyr
    feasible = (can_f > 0) & (can_r > 0) & ((fl > 0) | (rl > 0))
    out[:] = steer, phi, af, ar, fyf, fyr, feasible


def numpy_yaw_loop(
    lam: np.ndarray,
    V: np.ndarray,
    B: np.ndarray,
    grid: np.ndarray,
    f: np.ndarray,
    f_max: float,
    out: np.ndarray,
) -> None:
    """:func:`handling_kernel.yaw_loop` as numpy passes over the rows (the weights by
    numpy's solve, ``e^(lam t)`` by ``exp`` at every grid point)."""
    c = np.linalg.solve(V, B[..., None].astype(complex))[..., 0]  # (n, 4)
    w = V[:, 1, :] * c / lam
    r_ss = -np.sum(w, axis=1).real
    wn = w / r_ss[:, None]
    out[:, 5] = r_ss

    def y(t: np.ndarray, *orders: int) -> list[np.ndarray]:
        ex = np.exp(lam[:, None, :] * t[..., None])
        lo = lam[:, None, :]
        return [((ex * lo**o - (o == 0)) @ wn[:, :, None])[..., 0].real for o in orders]

    def rel_gain(fr: np.ndarray) -> np.ndarray:
        s = 2j * np.pi * fr[..., None]
        return np.abs(((lam[:, None, :] / (s - lam[:, None, :])) @ wn[:, :, None])[..., 0])

    n, rows, dt = lam.shape[0], np.arange(lam.shape[0]), grid[1] - grid[0]
    (yg,) = y(np.broadcast_to(grid, (n, grid.size)), 0)
    k = np.maximum(np.argmax(yg >= 0.9, axis=1), 1)
    t90 = (k - 1 + (0.9 - yg[rows, k - 1]) / (yg[rows, k] - yg[rows, k - 1])) * dt
    j = np.argmax(yg, axis=1)
    tp = grid[np.clip(j, 1, grid.size - 2)]
    for _ in range(4):
        y0, y1, y2 = y(np.column_stack([t90, tp]), 0, 1, 2)
        t90, tp = t90 - (y0[:, 0] - 0.9) / y1[:, 0], tp - y1[:, 1] / y2[:, 1]
    out[:, 0], out[:, 1] = t90, tp
    out[:, 2] = (j > 0) & (j < grid.size - 1)
    out[:, 3] = y(tp[:, None], 0)[0][:, 0]
    half = np.sqrt(0.5)
    g = rel_gain(np.broadcast_to(f, (n, f.size))) - half
    below = g < 0
    k = np.maximum(np.argmax(below, axis=1), 1)
    lo, hi = np.log(f[k - 1]), np.log(f[k])
    g_lo, g_hi = g[rows, k - 1], g[rows, k]
    side = np.zeros(n, dtype=np.int8)
    for _ in range(10):
        span = g_lo - g_hi
        mid = np.where(span > 0, (lo * -g_hi + hi * g_lo) / np.where(span > 0, span, 1.0), hi)
        g_mid = rel_gain(np.exp(mid)[:, None])[:, 0] - half
        under = g_mid < 0
        g_lo = np.where(under & (side == -1), 0.5 * g_lo, g_lo)
        g_hi = np.where(~under & (side == 1), 0.5 * g_hi, g_hi)
        hi, g_hi = np.where(under, mid, hi), np.where(under, g_mid, g_hi)
        lo, g_lo = np.where(under, lo, mid), np.where(under, g_lo, g_mid)
        side = np.where(under, -1, 1).astype(np.int8)
    best = np.where(np.abs(g_lo) < np.abs(g_hi), lo, hi)
    out[:, 4] = np.where(below.any(axis=1), np.exp(best), f_max)


@contextlib.contextmanager
def numpy_loops() -> Iterator[None]:
    """The handling kernel's loops replaced by their numpy passes while inside."""
    names = ("capacity_loop", "sweep_loop", "yaw_loop")
    saved = [getattr(handling_kernel, k) for k in names]
    for k, fn in zip(names, (numpy_capacity_loop, numpy_sweep_loop, numpy_yaw_loop), strict=True):
        setattr(handling_kernel, k, fn)
    try:
        yield
    finally:
        for k, fn in zip(names, saved, strict=True):
            setattr(handling_kernel, k, fn)


class NumpyLoops(MinibusRideHandling):
    """The default problem evaluated with :func:`numpy_loops` (the same numbers to
    rounding: tests/test_minibus_handling_linear.py)."""

    def _evaluate(self, X: np.ndarray) -> Any:
        with numpy_loops():
            return super()._evaluate(X)


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

    def _ride(self, X: np.ndarray, params: Any) -> dict[str, dict[str, np.ndarray]]:
        return full_model_ride(X, self)


def steady_loads(P: HandlingParams, ay: np.ndarray) -> tuple[np.ndarray, ...]:
    """Roll and wheel loads (FL, FR, RL, RR) of the steady state at lateral acceleration
    ``ay`` in numpy: :func:`wheel_loads` at zero roll rate (no damper moments)."""
    phi = P.roll_gradient() * ay
    fl, fr, rl, rr, _, _ = wheel_loads(P, phi, None, ay)
    return phi, fl, fr, rl, rr


def steady_circle_bisection(
    P: HandlingParams, config: SteadyCircleConfig | None = None
) -> np.ndarray:
    """Maximum quasi-steady lateral acceleration (n,) [m/s^2] by the previous search:
    plain bisection with the grid-search axle capacity (:func:`axle_capacity`) at every
    step; the reference of :func:`steady_circle` (tests) and part of the baseline."""
    cfg = config or SteadyCircleConfig()
    lo = np.zeros(P.n)
    hi = np.full(P.n, cfg.ay_upper)
    L = P.wheelbase
    for _ in range(int(np.ceil(np.log2(cfg.ay_upper / cfg.tolerance)))):
        mid = 0.5 * (lo + hi)
        _, fl, fr, rl, rr = steady_loads(P, mid)
        ok = (
            (axle_capacity(P.tyre, fl, fr, cfg)[0] >= P.m * mid * P.b / L)
            & (axle_capacity(P.tyre, rl, rr, cfg)[0] >= P.m * mid * P.a / L)
            & ((fl > 0) | (rl > 0))
        )
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    return lo


def baseline_measures(problem: MinibusRideHandling, X: np.ndarray) -> np.ndarray:
    """The evaluation before the handling changes, for timing: spectral ride (the previous
    algorithm, :func:`full_model_ride`), bisection steady circle, time-domain slalom;
    returns the five objectives (n, 5)."""
    X = np.atleast_2d(X)
    n = X.shape[0]
    ride = full_model_ride(X, problem)
    P = handling_parameters(X, LOAD_CASES, problem.vehicle)
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
    """``evaluate`` of :func:`baseline_measures`, shaped as a problem's (``ok`` per row)."""

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
    """Per-candidate times of several evaluators: the whole batch X (best of ``repeats``)
    and its first ``singles[j]`` rows one at a time (median), the measurements
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


def compiled_floor(problem: MinibusRideHandling, x: np.ndarray) -> dict[str, float]:
    """CPU ms of one evaluation of design ``x`` (1, 8) spent inside LAPACK
    (``numpy.linalg`` eig, eigvals, solve; ``spectral_kernel.lapack_eig``) and the compiled
    loops, by kind: each call recorded with its arguments during one evaluation, then
    timed alone (best of 5 blocks of 50). What a compiled pipeline around the same
    LAPACK calls would still pay; the rest of the single call is Python and numpy call overhead."""
    calls: list[tuple[str, Callable[..., Any], list[Any]]] = []
    lazy_call = compiled.Lazy.__call__

    def record(self: compiled.Lazy, *args: Any) -> Any:
        calls.append(
            (self._main.__name__.lstrip("_"), functools.partial(lazy_call, self), list(args))
        )
        return lazy_call(self, *args)

    saved = {(np.linalg, k): getattr(np.linalg, k) for k in ("eig", "eigvals", "solve")}
    saved[(spectral_kernel, "lapack_eig")] = spectral_kernel.lapack_eig  # the same gufunc

    def lapack(owner: Any, name: str) -> Callable[..., Any]:
        def run(*args: Any) -> Any:
            fn = saved[(owner, name)]
            calls.append((f"{owner.__name__}.{name}", fn, list(args)))
            return fn(*args)

        return run

    compiled.Lazy.__call__ = record  # type: ignore[method-assign]
    for owner, k in saved:
        setattr(owner, k, lapack(owner, k))
    try:
        problem.evaluate(x)
    finally:
        compiled.Lazy.__call__ = lazy_call  # type: ignore[method-assign]
        for (owner, k), fn in saved.items():
            setattr(owner, k, fn)
    out: dict[str, float] = {}
    for name, fn, args in calls:
        copies = [[a.copy() if isinstance(a, np.ndarray) else a for a in args] for _ in range(250)]
        best = np.inf
        for block in range(5):
            c0 = time.process_time()
            for a in copies[50 * block : 50 * (block + 1)]:
                fn(*a)
            best = min(best, (time.process_time() - c0) / 50)
        out[name] = out.get(name, 0.0) + 1e3 * best
    return out


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
    numpy_form = NumpyLoops()
    previous = PreviousDefault()
    study = MinibusRideHandling(handling="study")
    rng = np.random.default_rng(0)
    X = problem.space.to_physical(rng.random((args.batch, problem.space.dim)))
    for ev in (problem, numpy_form, previous):  # warm-up: imports, compiled loops, tables
        ev.evaluate(X[:2])

    # parts of the default evaluation (CPU ms per design, batched and one at a time)
    def params(Z: np.ndarray) -> HandlingParams:
        return handling_parameters(Z, LOAD_CASES)

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
        "default set's handling measures (both loads, with parameters)": lambda Z: (
            problem._standard_handling(params(Z))
        ),
    }
    evaluators = [problem, numpy_form, previous, study, _Baseline(problem)]
    timings = _interleaved(
        [*evaluators, *(_Part(fn) for fn in parts.values())],
        X,
        repeat,
        [n_single, n_single, n_single, n_single_slow, n_single_slow, *([n_single] * len(parts))],
    )
    t_new, t_numpy, t_prev, t_study, t_base = timings[:5]
    floor = compiled_floor(problem, X[:1])
    print("compiled floor of one design (ms):", {k: round(v, 4) for k, v in floor.items()})
    part_rows: list[dict[str, Any]] = []
    single_ms: list[float] = []
    for name, t in zip(parts, timings[5:], strict=True):
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
        *t_numpy.rows(
            f"default, handling searches as numpy passes (before), batch of {args.batch}",
            "default, handling searches as numpy passes (before), one at a time",
        ),
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
        "numpy_loops_ms_per_candidate_batched": t_numpy.batched_cpu_ms,
        "numpy_loops_ms_per_call_single": t_numpy.single_cpu_ms,
        "speedup_batched_vs_numpy_loops": t_numpy.batched_cpu_ms / t_new.batched_cpu_ms,
        "speedup_single_vs_numpy_loops": t_numpy.single_cpu_ms / t_new.single_cpu_ms,
        "handling_ms_per_call_single": single_ms[5],
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
        "floor_ms_per_call_single": sum(floor.values()),
        "floor_share_of_single_call": sum(floor.values()) / t_new.single_cpu_ms,
        "floor_ms_by_kind": floor,
        "target_single_ms": TARGET_SINGLE_MS,
        "target_single_compiled_ms": TARGET_SINGLE_COMPILED_MS,
        "target_batched_ms": TARGET_BATCHED_MS,
        "meets_single_target": bool(t_new.single_cpu_ms <= TARGET_SINGLE_MS),
        "meets_single_compiled_target": bool(t_new.single_cpu_ms <= TARGET_SINGLE_COMPILED_MS),
        "meets_batched_target": bool(t_new.batched_cpu_ms <= TARGET_BATCHED_MS),
        "study_30000_evaluations_cpu_s_estimate": STUDY_EVALUATIONS * t_new.batched_cpu_ms / 1e3,
        "load_average_1min": os.getloadavg()[0],
    }
    cmd = "python -m benchmarks.minibus_speed" + (" --quick" if args.quick else "")
    write_result("minibus_speed", rows, summary, cmd, args.output_dir)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
