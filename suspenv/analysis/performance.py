"""Fixed-budget and fixed-target views of best-so-far curves (minimisation).

A run is its best-so-far curve ``b[n]``, n = 1..N evaluations: the lowest quality of any
feasible evaluation among the first n, ``+inf`` before the first feasible one. Curves are
non-increasing by construction.

- :func:`curve_matrix`: curves of several runs as one (runs, n) array; a run that stopped
  before ``length`` keeps its final value (it has nothing better to offer).
- :func:`curve_quantiles`: per evaluation count, quantiles over runs with ``+inf`` counted
  as the worst value (not dropped). Each quantile of pointwise non-increasing curves is
  non-increasing, so the median curve never rises (dropping runs without a value, as a
  NaN-median does, makes it rise when a bad run gets its first value).
- :func:`make_targets`, :func:`runtimes`, :func:`ert`, :func:`runtime_ecdf`: the
  fixed-target view of COCO (Hansen et al.).
- :func:`performance_profile`: Dolan & Moré (2002).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.runs.quality import best_so_far

#: quantiles reported for best-so-far spread: min, lower quartile, median, upper quartile, max
QUANTILES = (0.0, 0.25, 0.5, 0.75, 1.0)
#: the column name of each of :data:`QUANTILES`
QUANTILE_NAMES = {0.0: "min", 0.25: "q25", 0.5: "median", 0.75: "q75", 1.0: "max"}


def as_curve(values: Sequence[float | None] | np.ndarray) -> np.ndarray:
    """A best-so-far curve from stored values (None/NaN before the first feasible -> inf),
    made non-increasing (running minimum) whatever was stored."""
    return best_so_far(np.array([np.nan if x is None else x for x in values], dtype=float))


def curve_matrix(curves: Sequence[np.ndarray], length: int | None = None) -> np.ndarray:
    """(runs, length) array of best-so-far curves; ``length`` defaults to the longest run.
    A shorter run is extended with its final value (``+inf`` if it has none)."""
    if not curves:
        return np.zeros((0, int(length or 0)))
    n = int(length if length is not None else max(len(c) for c in curves))
    M = np.full((len(curves), n), np.inf)
    for i, c in enumerate(curves):
        c = np.asarray(c, dtype=float)[:n]
        M[i, : len(c)] = c
        if 0 < len(c) < n:
            M[i, len(c) :] = c[-1]
    return M


def quantile_inf(values: np.ndarray, q: float, axis: int = 0) -> np.ndarray:
    """Quantile with linear interpolation between order statistics (numpy's default rule)
    where ``+inf`` is a value like any other: interpolating towards ``+inf`` with a positive
    weight gives ``+inf`` (never NaN)."""
    a = np.sort(np.asarray(values, dtype=float), axis=axis)
    a = np.moveaxis(a, axis, 0)
    k = a.shape[0]
    if k == 0:
        raise ValidationError("a quantile needs at least one value, but got none")
    h = (k - 1) * float(q)
    lo, hi = int(np.floor(h)), int(np.ceil(h))
    g = h - lo
    below, above = a[lo], a[hi]
    if g == 0:
        return np.asarray(below)
    with np.errstate(invalid="ignore"):
        mixed = below + g * (above - below)
    return np.where(np.isinf(above) | np.isinf(below), np.maximum(below, above), mixed)


def curve_quantiles(
    M: np.ndarray, quantiles: Sequence[float] = QUANTILES
) -> dict[float, np.ndarray]:
    """Per evaluation count (column of M), each quantile over the runs (rows); ``+inf``
    (no feasible value yet) counts as the worst value."""
    return {float(q): quantile_inf(M, q, axis=0) for q in quantiles}


def fixed_budget(M: np.ndarray, budgets: Sequence[int]) -> list[dict[str, float | int]]:
    """Quality reached within each budget (evaluation count, 1-based): quantiles over runs
    and the number of runs with a feasible value by then."""
    rows = []
    for b in budgets:
        b = int(b)
        if not 1 <= b <= M.shape[1]:
            raise ValidationError(
                f"a fixed budget must lie in [1, {M.shape[1]}] evaluations, but got {b}"
            )
        col = M[:, b - 1]
        row: dict[str, float | int] = {"budget": b, "n_with_value": int(np.isfinite(col).sum())}
        for q in QUANTILES:
            row[QUANTILE_NAMES[q]] = float(quantile_inf(col, q))
        rows.append(row)
    return rows


def make_targets(
    finals: Sequence[float], f_opt: float | None = None, n_targets: int = 21
) -> np.ndarray:
    """Target values from the runs' final qualities, easiest (highest) first.

    With a known optimum ``f_opt`` (COCO): ``f_opt + 10^k`` for ``n_targets`` values of k
    evenly spaced between ``log10(worst final - f_opt)`` and ``log10(best final - f_opt)``
    (the best precision floored at 1e-8 of the worst, so a run that hit the optimum
    exactly still gives a finite set). Without it: evenly spaced in log10 of the value
    between the worst and best final when both are positive, else evenly spaced linearly.
    Runs without a feasible value are left out; none at all gives an empty set.
    """
    v = np.asarray([x for x in finals if x is not None and np.isfinite(x)], dtype=float)
    if not v.size:
        return np.zeros(0)
    n = max(1, int(n_targets))
    worst, best = float(v.max()), float(v.min())
    if f_opt is not None:
        d_worst = worst - f_opt
        if d_worst <= 0:  # every run reached the optimum
            return np.array([float(f_opt)])
        d_best = max(best - f_opt, 1e-8 * d_worst)
        t = f_opt + np.logspace(np.log10(d_worst), np.log10(d_best), n)
    elif worst == best:
        return np.array([worst])
    elif best > 0:
        t = np.logspace(np.log10(worst), np.log10(best), n)
    else:
        t = np.linspace(worst, best, n)
    # the ends are the finals themselves (10**log10(v) may round below v, and the best
    # run would then miss the hardest target it defines)
    t[0] = worst
    if f_opt is None or best - f_opt >= 1e-8 * (worst - f_opt):
        t[-1] = best
    return t


def runtimes(curve: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Evaluations (1-based) until the best-so-far first reaches each target
    (``b[n] <= target``); ``inf`` when it never does."""
    c = np.asarray(curve, dtype=float)
    t = np.asarray(targets, dtype=float)
    out = np.full(t.shape, np.inf)
    if not c.size:
        return out
    # c is non-increasing: the first n with c[n] <= t is found by a search on -c
    idx = np.searchsorted(-c, -t, side="left")
    hit = idx < c.size
    out[hit] = idx[hit] + 1
    return out


def runtime_matrix(curves: Sequence[np.ndarray], targets: np.ndarray) -> np.ndarray:
    """(runs, targets) runtimes of several runs."""
    return np.array([runtimes(c, targets) for c in curves]).reshape(len(curves), len(targets))


def ert(rt: np.ndarray, evaluations: Sequence[int]) -> np.ndarray:
    """Expected running time per target (Hansen et al., COCO):

    ``ERT = (sum over runs of RT_i if the run reached the target, else its evaluations
    N_i) / (number of runs that reached it)``; ``inf`` when none did.

    ``rt``: (runs, targets) runtimes; ``evaluations``: evaluations each run used.
    """
    rt = np.atleast_2d(np.asarray(rt, dtype=float))
    N = np.asarray(evaluations, dtype=float).reshape(-1, 1)
    if N.shape[0] != rt.shape[0]:
        raise ValidationError(
            f"ERT needs one evaluation count per run ({rt.shape[0]}), but got {N.shape[0]}"
        )
    success = np.isfinite(rt)
    spent = np.where(success, rt, N).sum(axis=0)
    k = success.sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(k > 0, spent / np.maximum(k, 1), np.inf)


def runtime_ecdf(rt: np.ndarray, budgets: np.ndarray) -> np.ndarray:
    """Empirical cumulative distribution of runtimes over all (run, target) pairs: the
    fraction of pairs with ``RT <= x`` for every x in ``budgets`` (COCO's runtime ECDF,
    without simulated restarts)."""
    r = np.asarray(rt, dtype=float).ravel()
    x = np.asarray(budgets, dtype=float)
    if not r.size:
        return np.zeros(x.shape)
    s = np.sort(r)
    return np.searchsorted(s, x, side="right") / r.size


def ecdf_area(rt: np.ndarray, max_evaluations: int) -> float:
    """Area under the runtime ECDF over log10 evaluations from 1 to ``max_evaluations``,
    divided by that log range: 1 when every target is reached at the first evaluation,
    0 when none is ever reached (an aggregate COCO and IOHanalyzer both show)."""
    r = np.asarray(rt, dtype=float).ravel()
    if not r.size or max_evaluations <= 1:
        return float("nan")
    L = np.log10(max_evaluations)
    hits = r[np.isfinite(r) & (r <= max_evaluations)]
    return float(np.sum(L - np.log10(hits)) / (r.size * L))


def performance_profile(
    cost: np.ndarray, taus: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dolan & Moré (2002) performance profile.

    ``cost`` (instances, solvers), lower is better, ``inf`` for a failure. Ratio
    ``r[p, s] = cost[p, s] / min_s cost[p, s]`` (``inf`` for a failure, and for every
    solver when all failed on p); profile ``rho_s(tau) = |{p : r[p, s] <= tau}| / |P|``.
    Costs must be > 0 (a cost of 0 is raised to the smallest positive cost of the
    instance, or 1e-300).

    Returns ``(taus, rho (solvers, taus), ratios (instances, solvers))``; taus default to
    the distinct finite ratios (where the step functions jump), starting at 1.
    """
    C = np.atleast_2d(np.asarray(cost, dtype=float)).copy()
    if (C < 0).any():
        raise ValidationError("performance-profile costs must be >= 0, but got a negative one")
    for p in range(C.shape[0]):
        row = C[p]
        pos = row[np.isfinite(row) & (row > 0)]
        row[row == 0] = pos.min() if pos.size else 1e-300
    best = C.min(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        R = np.where(np.isfinite(C) & np.isfinite(best), C / best, np.inf)
    if taus is None:
        fin = R[np.isfinite(R)]
        taus = np.unique(np.r_[1.0, fin])
    taus = np.asarray(taus, dtype=float)
    rho = (R[:, :, None] <= taus[None, None, :]).mean(axis=0)
    return taus, rho, R
