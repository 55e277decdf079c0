"""Identified parameters and their quality (Tey et al. 2014, steps 8-9, and beyond).

- :func:`rerank_archive`: the rank-sum of Tey et al. over the *whole* archive at once
  (every objective min-max normalised over all valid evaluations, then summed).
- :func:`identify`: the best ``top`` designs of that ranking give each parameter as
  mean and sample standard deviation (the paper's Table 1).
- :func:`improvement_table`: each objective's mismatch for the initial and the identified
  model, and the improvement in percent (the paper's Table 2).
- :func:`recovery_table`: error of every identified parameter against the known truth.
- :func:`profile_scan` and :func:`local_sensitivity`: identifiability evidence. A
  parameter whose profile (total scaled mismatch as that parameter sweeps its whole range,
  the others held at the identified values) barely rises is not identified by the data.

- :class:`FixedRankSum`: the rank-sum with its normalisation frozen on the design of
  experiments, comparable across generations and runs (convergence, strategy comparison).

Scaled mismatch (profiles, sensitivity): each objective divided by its spread over the
design of experiments (max - min); sums of it are in "DoE spreads".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.core.space import DesignSpace


def objective_scale(F: np.ndarray) -> np.ndarray:
    """(m,) spread (max - min) of each column over its finite rows; 1 where it is 0 or unknown."""
    F = np.asarray(F, dtype=float)
    F = F[np.isfinite(F).all(axis=1)]
    if F.shape[0] == 0:
        return np.ones(F.shape[1])
    s = F.max(axis=0) - F.min(axis=0)
    return np.where(s > 0, s, 1.0)


@dataclass(frozen=True)
class FixedRankSum:
    """The rank-sum with its normalisation frozen on a reference set (the DoE).

    ``total_i = scale * sum_j (|F_ij| - low_j) / span_j`` with ``low`` and ``span`` the
    minimum and spread (max - min) of each column over the reference designs. Unlike the
    per-generation rank-sum it does not change when other designs are added, so it can
    measure convergence and compare runs; an objective whose mismatch cannot be reduced
    (a constant offset) adds a constant, not a dominating term. Below 0: better than every
    reference design on balance.
    """

    low: np.ndarray
    span: np.ndarray
    scale: float = 10.0

    @classmethod
    def fit(cls, F: np.ndarray, scale: float = 10.0) -> FixedRankSum:
        """Freeze the normalisation on the finite rows of F (n, m)."""
        F = np.abs(np.asarray(F, dtype=float))
        F = F[np.isfinite(F).all(axis=1)]
        if F.shape[0] == 0:
            raise ValidationError("FixedRankSum.fit needs at least one finite row, but got none")
        return cls(F.min(axis=0), objective_scale(F), float(scale))

    def subset(self, columns: Sequence[int]) -> FixedRankSum:
        idx = list(columns)
        return FixedRankSum(self.low[idx], self.span[idx], self.scale)

    def __call__(self, F: np.ndarray) -> np.ndarray:
        """(n,) totals; NaN for rows with a non-finite entry."""
        F = np.abs(np.atleast_2d(np.asarray(F, dtype=float)))
        if F.shape[1] != self.low.size:
            raise ValidationError(
                f"FixedRankSum: `n_columns == {self.low.size}` must hold, but got {F.shape[1]}"
            )
        return self.scale * ((F - self.low) / self.span).sum(axis=1)


def rerank_archive(F: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(N,) rank-sum of every valid row over the whole archive; NaN for the others."""
    from suspenv.core.scalarize import rank_sum

    return rank_sum(np.abs(np.asarray(F, dtype=float)), valid=np.asarray(valid, bool))


@dataclass
class IdentificationResult:
    """Paper Table 1: the identified parameters.

    Attributes:
        names, units: parameter labels.
        mean, std: (d,) mean and sample standard deviation over the best ``top`` designs.
        top_rows: archive rows of the best designs, best first.
        fitness: (N,) archive rank-sum (NaN for invalid rows).
        best: (d,) the single best design.
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    mean: np.ndarray
    std: np.ndarray
    top_rows: np.ndarray
    fitness: np.ndarray
    best: np.ndarray

    def rows(self) -> list[dict[str, object]]:
        return [
            {"parameter": n, "unit": u, "mean": float(m), "std": float(s)}
            for n, u, m, s in zip(self.names, self.units, self.mean, self.std, strict=True)
        ]


def identify(
    X: np.ndarray, F: np.ndarray, valid: np.ndarray, space: DesignSpace, top: int = 20
) -> IdentificationResult:
    """Re-rank the archive (X (N, d), F (N, m)) and summarise its best ``top`` designs."""
    X = space.check_batch(X, what="archive designs")
    F = np.asarray(F, dtype=float)
    valid = np.asarray(valid, bool) & np.isfinite(F).all(axis=1)
    if F.shape[0] != X.shape[0] or valid.shape != (X.shape[0],):
        raise ValidationError(
            f"X, F and valid must have the same rows, but got ({X.shape[0]}, {F.shape[0]}, "
            f"{valid.shape[0]})"
        )
    n_valid = int(valid.sum())
    if n_valid < 2 or int(top) < 1:
        raise ValidationError(
            f"identification needs `n_valid >= 2` and `top >= 1`, but got (n_valid={n_valid}, "
            f"top={top})"
        )
    fit = rerank_archive(F, valid)
    order = np.argsort(np.where(valid, fit, np.inf), kind="stable")[: min(int(top), n_valid)]
    sel = X[order]
    std = sel.std(axis=0, ddof=1) if sel.shape[0] > 1 else np.zeros(X.shape[1])
    return IdentificationResult(
        space.names, space.units, sel.mean(axis=0), std, order, fit, X[order[0]].copy()
    )


def improvement_table(
    f_initial: np.ndarray, f_identified: np.ndarray, names: Sequence[str]
) -> list[dict[str, object]]:
    """Paper Table 2: mismatch of the initial and identified model per objective.

    improvement_% = 100 (|initial| - |identified|) / |initial| (NaN when initial is 0).
    """
    a = np.abs(np.asarray(f_initial, dtype=float).reshape(-1))
    b = np.abs(np.asarray(f_identified, dtype=float).reshape(-1))
    if a.shape != b.shape or a.size != len(names):
        raise ValidationError(
            f"initial, identified and names must have the same length, but got "
            f"({a.size}, {b.size}, {len(names)})"
        )
    with np.errstate(divide="ignore", invalid="ignore"):
        imp = np.where(a > 0, 100.0 * (a - b) / a, np.nan)
    return [
        {"objective": n, "initial": float(x), "identified": float(y), "improvement_%": float(i)}
        for n, x, y, i in zip(names, a, b, imp, strict=True)
    ]


def recovery_table(
    result: IdentificationResult, truth: np.ndarray, space: DesignSpace
) -> list[dict[str, object]]:
    """Error of the identified mean against the truth, absolute and in % of the range."""
    truth = np.asarray(truth, dtype=float).reshape(-1)
    if truth.size != space.dim:
        raise ValidationError(f"truth must have {space.dim} values, but got {truth.size}")
    err = result.mean - truth
    rng = space.upper - space.lower
    with np.errstate(divide="ignore", invalid="ignore"):
        in_std = np.where(result.std > 0, np.abs(err) / result.std, np.inf)
    return [
        {
            "parameter": n,
            "unit": u,
            "truth": float(t),
            "identified": float(m),
            "error": float(e),
            "error_%_range": float(100.0 * abs(e) / r),
            "error_in_std": float(s),
        }
        for n, u, t, m, e, r, s in zip(
            space.names, space.units, truth, result.mean, err, rng, in_std, strict=True
        )
    ]


def evaluate_in_batches(
    problem: Problem,
    unit: np.ndarray,
    batch_size: int = 100,
    progress: bool = False,
    desc: str = "profiles",
) -> EvaluationBatch:
    """Evaluate unit-cube designs ``unit`` (n, d) ``batch_size`` rows at a time (each batch
    vectorised), with a progress bar named ``desc`` when ``progress``."""
    from tqdm.auto import tqdm

    unit = problem.space.check_batch(unit, what="unit design batch")
    if int(batch_size) < 1:
        raise ValidationError(f"`batch_size >= 1` must hold, but got batch_size={batch_size}")
    parts = []
    with tqdm(total=unit.shape[0], desc=desc, unit="design", disable=not progress) as bar:
        for start in range(0, unit.shape[0], int(batch_size)):
            parts.append(problem.evaluate_unit(unit[start : start + int(batch_size)]))
            bar.update(len(parts[-1]))
    return EvaluationBatch.concatenate(parts)


@dataclass
class ProfileScan:
    """Total scaled mismatch along each parameter's whole range, others held fixed.

    Attributes:
        names: parameter names (d).
        grid: (d, p) physical values visited for each parameter.
        score: (d, p) total scaled mismatch (NaN for failed evaluations).
        center_score: total scaled mismatch at the centre design.
        rise: (d,) max over the profile minus the centre score.

    Scores are sums of |objective| / DoE spread, so a rise of 1 means the objectives move
    by one DoE spread in total when the parameter sweeps its whole range.
    """

    names: tuple[str, ...]
    grid: np.ndarray
    score: np.ndarray
    center_score: float
    rise: np.ndarray

    def flat(self, tol: float = 0.05) -> np.ndarray:
        """(d,) True where the profile rises less than ``tol`` (DoE-spread units)."""
        return np.nan_to_num(self.rise, nan=0.0) < tol


def profile_scan(
    problem: Problem,
    x_center: np.ndarray,
    objectives: Sequence[int],
    scale: np.ndarray,
    n_points: int = 9,
    batch_size: int = 100,
    progress: bool = False,
) -> ProfileScan:
    """Sweep every parameter over its whole range (``n_points``), evaluated in batches.

    ``scale`` holds one spread per entry of ``objectives``.
    """
    space = problem.space
    x_center = space.check_batch(x_center)[0]
    if int(n_points) < 2:
        raise ValidationError(f"`n_points >= 2` must hold, but got n_points={n_points}")
    d, p = space.dim, int(n_points)
    u_center = np.clip(space.to_unit(x_center[None, :])[0], 0.0, 1.0)
    levels = np.linspace(0.0, 1.0, p)
    U = np.repeat(u_center[None, :], d * p + 1, axis=0)
    for i in range(d):
        U[i * p : (i + 1) * p, i] = levels
    batch = evaluate_in_batches(problem, U, batch_size, progress, desc="profiles")
    idx = list(objectives)
    tot = (np.abs(batch.objectives[:, idx]) / np.asarray(scale, dtype=float)).sum(axis=1)
    tot = np.where(batch.ok, tot, np.nan)
    score = tot[:-1].reshape(d, p)
    center = float(tot[-1])
    grid = space.to_physical(U[:-1])[np.arange(d * p), np.repeat(np.arange(d), p)].reshape(d, p)
    with np.errstate(invalid="ignore"):
        rise = np.nanmax(np.where(np.isfinite(score), score, -np.inf), axis=1) - center
    rise = np.where(np.isfinite(rise), np.maximum(rise, 0.0), np.nan)
    return ProfileScan(space.names, grid, score, center, rise)


@dataclass
class LocalSensitivity:
    """Finite-difference sensitivity of the scaled kept objectives at a design.

    Attributes:
        jacobian: (m, d) d(F_j / s_j) / du_i per unit-cube step (u in [0, 1]).
        signed: True when built from signed residuals (a ``residuals`` hook), so that
            ``singular_values`` and ``directions`` describe combinations of parameters;
            False when built from mismatch magnitudes (forward differences), in which
            case only column norms are meaningful.
        column_norm: (d,) Euclidean norm of each parameter's column.
        singular_values: (min(m, d),) descending.
        directions: (d, d) right singular vectors as rows (last rows: flattest).
    """

    jacobian: np.ndarray
    signed: bool
    column_norm: np.ndarray
    singular_values: np.ndarray
    directions: np.ndarray

    def _null_rows(self, tol: float) -> np.ndarray:
        d = self.directions.shape[0]
        sv = np.zeros(d)
        sv[: self.singular_values.size] = self.singular_values
        return self.directions[sv <= tol]

    def nullity(self, tol: float = 0.05) -> int:
        """Number of directions whose gain is at most ``tol``.

        Gain: change of the scaled objectives (DoE-spread units) per unit-cube step, i.e.
        over a parameter's whole range to first order.
        """
        return int(self._null_rows(tol).shape[0])

    def null_share(self, tol: float = 0.05) -> np.ndarray:
        """(d,) squared length of each parameter's unit vector inside the flat subspace.

        1: the parameter can change without any first-order effect on the objectives
        (alone or compensated by others); 0: every change of it is seen.
        """
        N = self._null_rows(tol)
        return (N**2).sum(axis=0)

    def flat_directions(self, tol: float = 0.05) -> np.ndarray:
        """Basis (rows) of the directions whose gain is at most ``tol`` (see :meth:`nullity`).

        The basis is put in reduced row-echelon form (each row scaled to max |v| = 1), so a
        planted combination such as ``b1 - b2`` shows as one row instead of a rotation.
        Meaningful when ``signed`` is True.
        """
        return readable_basis(self._null_rows(tol))


def readable_basis(N: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Reduced row-echelon form of the row space of N, rows scaled to max |entry| = 1."""
    A = np.array(N, dtype=float, copy=True)
    rows, cols = A.shape
    r = 0
    for c in range(cols):
        if r >= rows:
            break
        p = r + int(np.argmax(np.abs(A[r:, c])))
        if abs(A[p, c]) < tol:
            continue
        A[[r, p]] = A[[p, r]]
        A[r] /= A[r, c]
        others = np.arange(rows) != r
        A[others] -= np.outer(A[others, c], A[r])
        r += 1
    A = A[:r]
    A[np.abs(A) < tol] = 0.0
    return A / np.abs(A).max(axis=1, keepdims=True) if r else A


def local_sensitivity(
    problem: Problem,
    x: np.ndarray,
    objectives: Sequence[int],
    scale: np.ndarray,
    step: float = 1e-3,
) -> LocalSensitivity:
    """Jacobian of the scaled kept objectives with respect to the unit-cube parameters.

    Uses the problem's optional ``residuals(X) -> (n, m)`` hook (signed simulated minus
    measured values, same columns as the objectives) with central differences when it
    exists; otherwise forward differences of the mismatch magnitudes (objectives).
    """
    space = problem.space
    x = space.check_batch(x)[0]
    u = np.clip(space.to_unit(x[None, :])[0], 0.0, 1.0)
    d, h = space.dim, float(step)
    idx = list(objectives)
    s = np.asarray(scale, dtype=float)[: len(idx)]
    hook = getattr(problem, "residuals", None)
    eye = np.eye(d) * h
    if callable(hook):
        up = np.clip(u + eye, 0.0, 1.0)
        dn = np.clip(u - eye, 0.0, 1.0)
        R = np.asarray(hook(space.to_physical(np.vstack([up, dn]))), dtype=float)[:, idx] / s
        du = (up - dn)[np.arange(d), np.arange(d)]
        J = ((R[:d] - R[d:]) / np.where(du > 0, du, 1.0)[:, None]).T
        signed = True
    else:
        sgn = np.where(u + h <= 1.0, 1.0, -1.0)
        U = np.vstack([u[None, :], u + eye * sgn[:, None]])
        F = np.abs(problem.evaluate(space.to_physical(U)).objectives[:, idx]) / s
        J = ((F[1:] - F[0]) / (h * sgn[:, None])).T
        signed = False
    J = np.nan_to_num(J)
    _, sv, Vt = np.linalg.svd(J, full_matrices=True)
    return LocalSensitivity(J, signed, np.linalg.norm(J, axis=0), sv, Vt)
