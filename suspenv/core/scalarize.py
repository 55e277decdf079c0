"""Scalarisers: several objectives (n, m) -> one fitness (n,) for single-objective strategies.

``rank_sum`` is the "dynamic summation of rank" of Tey et al. (2014): within one batch
(one generation), each objective column j is min-max normalised over the batch,
``R_ij = (F_ij - min_j) / (max_j - min_j) * 10``, and ``fitness_i = sum_j R_ij``. A column
that is constant over the batch contributes 0. Only rows flagged ``valid`` take part in
the min/max; the others get NaN.

``penalized_fitness`` orders a batch for a minimiser: feasible rows keep their fitness;
infeasible rows rank after every feasible row, ordered by their constraint violation;
failed rows rank after everything. Tey et al. removed infeasible designs before sorting;
here they are kept (CMA-ES must be told the whole population) but always sorted last.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from suspenv.core.errors import ValidationError

Scalarizer = Callable[[np.ndarray], np.ndarray]


def _as_2d(F: np.ndarray) -> np.ndarray:
    F = np.asarray(F, dtype=float)
    if F.ndim == 1:
        F = F[:, None]
    if F.ndim != 2:
        raise ValidationError(f"objectives must have shape (n, m), but got {np.shape(F)}")
    return F


def weighted_sum(
    F: np.ndarray, weights: Sequence[float] | None = None, valid: np.ndarray | None = None
) -> np.ndarray:
    """sum_j w_j F_ij (equal weights 1 by default); NaN where ``valid`` is False."""
    F = _as_2d(F)
    w = np.ones(F.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (F.shape[1],):
        raise ValidationError(
            f"weighted_sum: `len(weights) == n_objectives` must hold, but got "
            f"(len(weights)={w.size}, n_objectives={F.shape[1]})"
        )
    out = F @ w
    if valid is not None:
        out = np.where(np.asarray(valid, bool), out, np.nan)
    return out


def min_max_normalised(F: np.ndarray, scale: float = 10.0) -> np.ndarray:
    """Each column of F (n, m) min-max normalised to [0, scale] over the rows (a constant
    column gives 0)."""
    lo, hi = F.min(axis=0), F.max(axis=0)
    span = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(span > 0, (F - lo) / np.where(span > 0, span, 1.0), 0.0) * scale


def rank_sum(F: np.ndarray, valid: np.ndarray | None = None, scale: float = 10.0) -> np.ndarray:
    """Tey et al.'s dynamic rank-sum over one batch (:func:`min_max_normalised` over the
    valid rows, summed); NaN for rows not ``valid``."""
    F = _as_2d(F)
    ok = np.isfinite(F).all(axis=1) if valid is None else np.asarray(valid, bool)
    ok = ok & np.isfinite(F).all(axis=1)
    out = np.full(F.shape[0], np.nan)
    if not ok.any():
        return out
    out[ok] = min_max_normalised(F[ok], scale).sum(axis=1)
    return out


SCALARIZERS: dict[str, Callable[..., np.ndarray]] = {
    "weighted_sum": weighted_sum,
    "rank_sum": rank_sum,
}


def get_scalarizer(name: str) -> Callable[..., np.ndarray]:
    """Scalariser by name ("weighted_sum" or "rank_sum")."""
    try:
        return SCALARIZERS[name]
    except KeyError:
        raise ValidationError(
            f"unknown scalarizer {name!r} (known: {', '.join(sorted(SCALARIZERS))})"
        ) from None


def penalized_fitness(
    fitness: np.ndarray, ok: np.ndarray, violation: np.ndarray | None = None
) -> np.ndarray:
    """Finite fitness for every row: feasible < infeasible (by violation) < failed.

    Args:
        fitness: (n,) scalar fitness of each row (NaN allowed for failed rows).
        ok: (n,) evaluation succeeded.
        violation: (n,) total constraint violation sum(max(g, 0)), or None.
    """
    f = np.asarray(fitness, dtype=float).copy()
    ok = np.asarray(ok, bool) & np.isfinite(f)
    v = np.zeros_like(f) if violation is None else np.nan_to_num(np.asarray(violation, float))
    feasible = ok & (v <= 0)
    infeasible = ok & (v > 0)
    if feasible.any():
        top = f[feasible].max()
        span = max(top - f[feasible].min(), 1.0)
    else:
        top, span = 0.0, 1.0
    out = f
    if infeasible.any():
        out[infeasible] = top + span * (1.0 + v[infeasible] / max(v[infeasible].max(), 1e-300))
    worst = out[feasible | infeasible].max() if (feasible | infeasible).any() else 0.0
    out[~ok] = worst + 3.0 * span
    return out
