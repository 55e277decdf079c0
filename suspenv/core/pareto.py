"""Pareto dominance (minimisation) for reports: the non-dominated rows of an objective array."""

from __future__ import annotations

import numpy as np
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting


def nondominated(F: np.ndarray, candidates: np.ndarray | None = None) -> np.ndarray:
    """Boolean mask of the rows of F (n, m) that no other candidate row dominates.

    Rows outside ``candidates`` (default: all) or with non-finite values take no part.
    Uses pymoo's non-dominated sorting (compiled), fast for tens of thousands of rows.
    """
    F = np.atleast_2d(np.asarray(F, dtype=float))
    pool = np.isfinite(F).all(axis=1)
    if candidates is not None:
        pool &= np.asarray(candidates, bool)
    keep = np.zeros(F.shape[0], bool)
    idx = np.flatnonzero(pool)
    if idx.size:
        front = NonDominatedSorting().do(F[idx], only_non_dominated_front=True)
        keep[idx[np.asarray(front, dtype=int)]] = True
    return keep
