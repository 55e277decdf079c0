"""Multi-objective quality indicators (minimisation): hypervolume, IGD, reference fronts.

Every indicator here works in a *normalised* objective space: ``f' = (f - ideal) /
(nadir - ideal)`` with ``ideal`` and ``nadir`` the component-wise minimum and maximum of
the reference front (:func:`normalisation`). The hypervolume's reference point is
``1.1`` in every normalised objective, i.e. ``nadir + 0.1 (nadir - ideal)`` in the raw
objectives (:data:`REFERENCE_POINT_OFFSET`). For ZDT1 (ideal (0, 0), nadir (1, 1)) the
normalised and raw spaces coincide and the reference point is (1.1, 1.1).

- :func:`hypervolume`: exact. Two objectives: sort by the first and sum the rectangles
  (:func:`hypervolume_2d`, our own); three and more: pymoo's exact indicator
  (``pymoo.indicators.hv.HV``), checked in the tests against an independent exact
  dimension sweep (HSO) on small fronts.
- :func:`igd`: mean over the reference points of the Euclidean distance to the nearest
  point of the approximation set.
- :func:`hypervolume_curve`: the hypervolume of the feasible non-dominated set after every
  evaluation of a run (exact at every evaluation for two objectives; at up to
  ``checkpoints`` geometrically spaced evaluation counts for more, constant in between).
- :data:`KNOWN_FRONTS`: analytic Pareto fronts (ZDT1: ``f2 = 1 - sqrt(f1)``, f1 in [0, 1]).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.pareto import nondominated
from suspenv.problems.toy import ZDT1

#: the reference point is ``1 + REFERENCE_POINT_OFFSET`` in every normalised objective
REFERENCE_POINT_OFFSET = 0.1

#: hypervolumes are computed for at most this many objectives (exact cost grows fast)
HV_MAX_OBJECTIVES = 6


@dataclass(frozen=True)
class KnownFront:
    """An analytic Pareto front: ``sample(n)`` points on it and, where known, its exact
    hypervolume for a reference point given in the front's normalised space."""

    objectives: tuple[str, ...]
    sample: Callable[[int], np.ndarray]
    exact_hypervolume: Callable[[np.ndarray], float] | None
    source: str


def _zdt1_hypervolume(ref: np.ndarray) -> float:
    # ideal (0, 0), nadir (1, 1): the normalised front is the raw one. For r1, r2 >= 1 the
    # dominated area is r1 r2 minus the area under the front, int_0^1 (1 - sqrt f) df = 1/3
    r1, r2 = float(ref[0]), float(ref[1])
    if r1 < 1.0 or r2 < 1.0:
        raise ValidationError(
            f"the exact ZDT1 hypervolume needs a reference point >= (1, 1), but got {ref}"
        )
    return r1 * r2 - 1.0 / 3.0


#: analytic fronts by problem name (independent of the number of variables)
KNOWN_FRONTS: dict[str, KnownFront] = {
    "ZDT1": KnownFront(
        ("f1", "f2"),
        ZDT1.pareto_front,
        _zdt1_hypervolume,
        "analytic: f2 = 1 - sqrt(f1), f1 in [0, 1] (Zitzler, Deb, Thiele 2000)",
    ),
}


def _points(F: np.ndarray, what: str) -> np.ndarray:
    F = np.asarray(F, dtype=float)
    if F.ndim == 1:
        F = F[None, :]
    if F.ndim != 2:
        raise ValidationError(f"{what} must be an (n, m) array, but got shape {F.shape}")
    return F


def normalisation(front: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(ideal, nadir)`` of a reference front: its component-wise min and max. A
    degenerate objective (max == min) gets a span of 1."""
    P = _points(front, "reference front")
    P = P[np.isfinite(P).all(axis=1)]
    if not len(P):
        raise ValidationError("a reference front needs at least one finite point, but got none")
    ideal, nadir = P.min(axis=0), P.max(axis=0)
    nadir = np.where(nadir > ideal, nadir, ideal + 1.0)
    return ideal, nadir


def normalise(F: np.ndarray, ideal: np.ndarray, nadir: np.ndarray) -> np.ndarray:
    """``(F - ideal) / (nadir - ideal)``."""
    return (_points(F, "objectives") - ideal) / (nadir - ideal)


def hypervolume_2d(F: np.ndarray, ref: np.ndarray) -> float:
    """Exact hypervolume of a two-objective point set (minimisation) up to ``ref``.

    Points not strictly better than ``ref`` in both objectives add nothing. Sorted by f1
    (then f2), a point adds the rectangle between it, the next point's f1 and the lowest
    f2 seen so far: ``sum_i (x_{i+1} - x_i) (r2 - min_{j<=i} y_j)`` with ``x_{n+1} = r1``.
    """
    P = _points(F, "objectives")
    ref = np.asarray(ref, dtype=float)
    P = P[np.isfinite(P).all(axis=1) & (ref > P).all(axis=1)]
    if not len(P):
        return 0.0
    P = P[np.lexsort((P[:, 1], P[:, 0]))]
    low = np.minimum.accumulate(P[:, 1])
    widths = np.diff(np.r_[P[:, 0], ref[0]])
    return float(np.sum(widths * (ref[1] - low)))


def hypervolume(F: np.ndarray, ref: np.ndarray) -> float:
    """Exact hypervolume (minimisation) of the points F (n, m) up to the reference point.

    Non-finite rows and rows not strictly better than ``ref`` in every objective add
    nothing. m = 1: ``ref - min f``; m = 2: :func:`hypervolume_2d`; m >= 3: pymoo's exact
    indicator on the rows inside the reference box.
    """
    P = _points(F, "objectives")
    ref = np.asarray(ref, dtype=float)
    if ref.shape != (P.shape[1],):
        raise ValidationError(
            f"the reference point must have one value per objective ({P.shape[1]}), "
            f"but got {ref.tolist()}"
        )
    P = P[np.isfinite(P).all(axis=1) & (ref > P).all(axis=1)]
    if not len(P):
        return 0.0
    m = P.shape[1]
    if m == 1:
        return float(ref[0] - P[:, 0].min())
    if m == 2:
        return hypervolume_2d(P, ref)
    from pymoo.indicators.hv import HV

    return float(HV(ref_point=ref)(P[nondominated(P)]))


def igd(A: np.ndarray, reference: np.ndarray) -> float:
    """Inverted generational distance: ``mean_{r in R} min_{a in A} ||r - a||_2``.

    Zero when every reference point is in A; inf when A has no finite point."""
    from scipy.spatial import cKDTree

    A = _points(A, "approximation set")
    R = _points(reference, "reference front")
    A = A[np.isfinite(A).all(axis=1)]
    R = R[np.isfinite(R).all(axis=1)]
    if not len(R):
        raise ValidationError("IGD needs a reference front with at least one finite point")
    if not len(A):
        return float("inf")
    d, _ = cKDTree(A).query(R)
    return float(np.mean(d))


def reference_point(m: int) -> np.ndarray:
    """The hypervolume reference point in normalised space: 1.1 in every objective."""
    return np.full(int(m), 1.0 + REFERENCE_POINT_OFFSET)


def feasible_front(F: np.ndarray, feasible: np.ndarray) -> np.ndarray:
    """The non-dominated rows of F among the feasible, finite ones."""
    F = _points(F, "objectives")
    mask = np.asarray(feasible, bool) & np.isfinite(F).all(axis=1)
    if not mask.any():
        return np.zeros((0, F.shape[1]))
    return F[nondominated(F, mask)]


def hypervolume_curve(
    F: np.ndarray, feasible: np.ndarray, ref: np.ndarray, checkpoints: int = 60
) -> np.ndarray:
    """Hypervolume of the feasible non-dominated set of evaluations 1..i, for every i.

    ``F`` is already normalised and ``ref`` is in the same space. Two objectives: exact
    after every evaluation (the front is kept incrementally and its hypervolume recomputed
    when it changes). Three or more: computed at up to ``checkpoints`` geometrically
    spaced evaluation counts (and the last) and held constant until the next one, so a
    hypervolume target is reached at that checkpoint at the latest (runtimes are upper
    bounds). Non-decreasing by construction.
    """
    F = _points(F, "objectives")
    n, m = F.shape
    ok = np.asarray(feasible, bool) & np.isfinite(F).all(axis=1) & (ref > F).all(axis=1)
    out = np.zeros(n)
    if not n:
        return out
    if m == 2:
        front = np.zeros((0, 2))
        hv = 0.0
        for i in range(n):
            if ok[i]:
                p = F[i]
                if not (front <= p).all(axis=1).any():
                    front = np.vstack([front[~(p <= front).all(axis=1)], p])
                    hv = hypervolume_2d(front, ref)
            out[i] = hv
        return out
    marks = np.unique(np.r_[np.geomspace(1, n, max(2, int(checkpoints))).round().astype(int), n])
    prev, hv = 0, 0.0
    for k in marks:
        if ok[prev:k].any():
            hv = hypervolume(F[:k][ok[:k]], ref)
        out[prev:k] = out[prev - 1] if prev else 0.0
        out[k - 1] = hv
        prev = k
    return np.maximum.accumulate(out)
