"""Per-objective scales of the normalised env reward (``reward="normalized"``).

Objectives of one problem come in different units (the 40 K&C objectives of
``KCIdentification`` are mismatches in 8 units: N/mm^2, deg/mm, N*m/deg^2, ...), so their
plain sum weights them by accident of unit. The normalised reward divides objective j by a
scale ``s_j`` fixed by the problem alone, never by what an agent does:

* the scales the problem declares (:attr:`Problem.objective_scales
  <suspenv.core.problem.Problem.objective_scales>`) when it declares them: for
  ``KCIdentification`` the standard error of each measured objective
  (:func:`~suspenv.problems.kc_identification.objective_noise`), the same scales as its
  quality, so ``f_j / s_j`` is the mismatch in standard errors;
* otherwise this module's rule:

    s_j = max(|f_j(x_ref)|, SPREAD_FRACTION * IQR_j)    (then 1 where that is 0 or not finite)

* ``f_j(x_ref)``: the objective at the reference design (``problem.reference_design()``,
  the design ``reset()`` evaluates); 0 when the reference evaluation fails.
* ``IQR_j``: the interquartile range (75th minus 25th percentile) of objective j over a
  fixed sample of :data:`SAMPLE_SIZE` designs drawn uniformly in the unit cube with
  ``numpy.random.default_rng(SAMPLE_SEED)`` and mapped through the problem's design space;
  failed rows are left out (no valid row: IQR 0).
* :data:`SPREAD_FRACTION` = 0.1.

Consequences of the rule: at the reference design every objective contributes at most 1
to the normalised sum (exactly 1 unless the reference already matches it better than a
tenth of its spread), so an objective that no design moves (its spread is ~0, its scale is
its reference value) contributes 1 out of about m, wherever the agent goes; and the scale
of an objective the reference happens to match almost exactly is bounded below by a tenth
of its spread, so it cannot blow up. Declared scales carry no such bound: for
``KCIdentification`` (defaults) the reference design's normalised sum is 483 standard
errors, 17 % of it from each of the three worst-matched toe objectives (80 standard errors
each) and 0.05 % from ``opp_roll_rate`` (the plain sum gave it 57 %).

The rule's scales cost one batch evaluation of :data:`SAMPLE_SIZE` designs plus the
reference; declared scales what the problem spends on them (0.5-0.7 s once for
``KCIdentification``). Both are computed on first use and cached per problem name and
options (problems are deterministic).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.problem import Problem
from suspenv.core.result import check_scales

#: designs in the fixed sample that sets each objective's spread
SAMPLE_SIZE = 64
#: seed of that sample (``numpy.random.default_rng``)
SAMPLE_SEED = 0
#: the floor of a scale, as a fraction of the objective's interquartile range
SPREAD_FRACTION = 0.1


@dataclass(frozen=True)
class ObjectiveScales:
    """The scales ``s`` (m,) and what they were made of (all in the objectives' units;
    ``declared``: the problem's own scales, then ``reference`` and ``iqr`` are NaN)."""

    scales: np.ndarray
    reference: np.ndarray  # f(x_ref); NaN when the reference evaluation failed
    iqr: np.ndarray  # interquartile range over the sample (0 without 2 valid rows)
    n_valid: int  # valid rows in the sample
    names: tuple[str, ...] = field(default=())
    declared: bool = False


_CACHE: dict[str, ObjectiveScales] = {}


def cache_key(name: str, options: dict[str, Any] | None) -> str | None:
    """Key of a problem built from a registered name and options (None: do not cache)."""
    try:
        return json.dumps([name, options or {}], sort_keys=True)
    except (TypeError, ValueError):
        return None


def objective_scales(problem: Problem, key: str | None = None) -> ObjectiveScales:
    """The scales of ``problem``: its declared ones, else by the rule of this module
    (cached under ``key``)."""
    if key is not None and key in _CACHE:
        return _CACHE[key]
    out = _declared(problem)
    if out is None:
        out = _by_rule(problem)
    if key is not None:
        _CACHE[key] = out
    return out


def _declared(problem: Problem) -> ObjectiveScales | None:
    """The problem's declared scales (None without), or a ValidationError naming the
    rule and the values: one per objective, finite and > 0."""
    declared = problem.objective_scales
    if declared is None:
        return None
    m = problem.n_objectives
    s = check_scales(declared, m, "objective", f"{problem.name}: ")
    nan = np.full(m, np.nan)
    return ObjectiveScales(
        scales=s,
        reference=nan,
        iqr=nan.copy(),
        n_valid=0,
        names=tuple(problem.objective_names),
        declared=True,
    )


def _by_rule(problem: Problem) -> ObjectiveScales:
    """The scales of this module's rule (module docstring)."""
    m = problem.n_objectives
    ref_batch = problem.evaluate(problem.reference_design()[None, :])
    ref = np.asarray(ref_batch.objectives[0], dtype=float)
    ref_ok = bool(ref_batch.ok[0]) and np.isfinite(ref).all()
    rng = np.random.default_rng(SAMPLE_SEED)
    U = rng.uniform(0.0, 1.0, size=(SAMPLE_SIZE, problem.space.dim))
    batch = problem.evaluate(problem.space.to_physical(U))
    F = np.asarray(batch.objectives, dtype=float)
    valid = np.asarray(batch.ok, bool) & np.isfinite(F).all(axis=1)
    if valid.sum() >= 2:
        q1, q3 = np.percentile(F[valid], [25.0, 75.0], axis=0)
        iqr = q3 - q1
    else:
        iqr = np.zeros(m)
    s = np.maximum(np.abs(ref) if ref_ok else np.zeros(m), SPREAD_FRACTION * iqr)
    s = np.where(np.isfinite(s) & (s > 0), s, 1.0)
    return ObjectiveScales(
        scales=s,
        reference=ref if ref_ok else np.full(m, np.nan),
        iqr=iqr,
        n_valid=int(valid.sum()),
        names=tuple(problem.objective_names),
    )
