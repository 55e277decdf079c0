"""The result of evaluating a batch of designs, and its total constraint violation.

Total violation (the one definition; penalties, DE's ranking, the envs' reward and the
optimiser adapters all read it): ``v = sum_j max(g_j / s_j, 0)``, dimensionless, where
``g_j`` is constraint j in its own unit (feasible when <= 0) and ``s_j > 0`` the scale
the problem declares for it in the same unit (:attr:`Problem.constraint_scales
<suspenv.core.problem.Problem.constraint_scales>`, e.g. the magnitude of the limit the
constraint compares with; 1 for constraints that are already dimensionless). This is
pymoo's CV ``sum_j max(0, g_j)`` on constraints normalised as pymoo recommends
(``g = r / limit - 1`` for a response r and its limit). Dividing by ``s_j > 0`` leaves
the sign of every ``g_j``, so which designs are feasible does not depend on the scales.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from suspenv.core.errors import ValidationError


@dataclass
class EvaluationBatch:
    """Objectives, constraints and status of ``n`` evaluated designs.

    Attributes:
        objectives: (n, m) values to minimise; rows of failed designs are NaN.
        constraints: (n, k); a design is feasible when every entry is <= 0.
        ok: (n,) True where the evaluation succeeded.
        messages: n strings; the failure reason where ``ok`` is False, else "".
        extras: optional named per-row arrays (first axis n) a problem wants archived
            or reported, e.g. auxiliary metrics. Kept small.
        constraint_scales: (k,) scale of each constraint in its unit, finite and > 0
            (see the module docstring); None: every scale is 1. Set by
            :meth:`Problem.evaluate <suspenv.core.problem.Problem.evaluate>`.
    """

    objectives: np.ndarray
    constraints: np.ndarray
    ok: np.ndarray
    messages: list[str]
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    constraint_scales: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.objectives = np.atleast_2d(np.asarray(self.objectives, dtype=float))
        n = self.objectives.shape[0]
        c = np.asarray(self.constraints, dtype=float)
        self.constraints = c.reshape(n, -1) if c.size else np.zeros((n, 0))
        self.ok = np.asarray(self.ok, dtype=bool).reshape(-1)
        self.messages = list(self.messages)
        if self.ok.shape[0] != n or len(self.messages) != n or self.constraints.shape[0] != n:
            raise ValidationError(
                "EvaluationBatch parts must have the same number of rows, but got "
                f"objectives={self.objectives.shape}, constraints={self.constraints.shape}, "
                f"ok={self.ok.shape}, messages={len(self.messages)}"
            )
        if self.constraint_scales is not None:
            self.constraint_scales = check_scales(self.constraint_scales, self.constraints.shape[1])

    # ----------------------------------------------------------- constructors
    @classmethod
    def failed(cls, n: int, m: int, k: int, message: str) -> EvaluationBatch:
        """``n`` failed rows that all carry ``message``."""
        return cls(
            np.full((n, m), np.nan), np.full((n, k), np.nan), np.zeros(n, bool), [message] * n
        )

    @classmethod
    def concatenate(cls, parts: Sequence[EvaluationBatch]) -> EvaluationBatch:
        """Stack batches row-wise (extras only where every part has them)."""
        if not parts:
            raise ValidationError("cannot concatenate an empty list of batches")
        keys = set(parts[0].extras)
        for p in parts[1:]:
            keys &= set(p.extras)
        return cls(
            np.vstack([p.objectives for p in parts]),
            np.vstack([p.constraints for p in parts]),
            np.concatenate([p.ok for p in parts]),
            [m for p in parts for m in p.messages],
            {k: np.concatenate([np.asarray(p.extras[k]) for p in parts]) for k in sorted(keys)},
            next((p.constraint_scales for p in parts if p.constraint_scales is not None), None),
        )

    # ----------------------------------------------------------------- views
    def __len__(self) -> int:
        return self.objectives.shape[0]

    @property
    def n_objectives(self) -> int:
        return self.objectives.shape[1]

    @property
    def n_constraints(self) -> int:
        return self.constraints.shape[1]

    @property
    def scaled_constraints(self) -> np.ndarray:
        """(n, k) dimensionless constraints ``g_j / s_j`` (feasible when <= 0)."""
        if self.constraint_scales is None:
            return self.constraints
        return self.constraints / self.constraint_scales

    @property
    def violation(self) -> np.ndarray:
        """(n,) total constraint violation ``sum_j max(g_j / s_j, 0)`` (dimensionless, see
        the module docstring); NaN for failed rows."""
        if self.n_constraints == 0:
            return np.where(self.ok, 0.0, np.nan)
        v = np.clip(self.scaled_constraints, 0.0, None).sum(axis=1)
        return np.where(self.ok, v, np.nan)

    @property
    def feasible(self) -> np.ndarray:
        """(n,) True where ok and every constraint <= 0 (:func:`feasible`)."""
        return feasible(self.ok, self.constraints)

    @property
    def rankable(self) -> np.ndarray:
        """(n,) True where ok and every objective finite: the rows a strategy ranks."""
        return np.asarray(self.ok, bool) & np.isfinite(self.objectives).all(axis=1)

    def take(self, rows: np.ndarray | Sequence[int]) -> EvaluationBatch:
        """A sub-batch of the given rows."""
        idx = np.asarray(rows)
        return EvaluationBatch(
            self.objectives[idx],
            self.constraints[idx],
            self.ok[idx],
            [self.messages[i] for i in np.arange(len(self))[idx]],
            {k: np.asarray(v)[idx] for k, v in self.extras.items()},
            self.constraint_scales,
        )


def feasible(ok: np.ndarray, constraints: np.ndarray) -> np.ndarray:
    """(n,) True where ``ok`` and every constraint (n, k) is <= 0 (NaN: infeasible): the
    one rule (:attr:`EvaluationBatch.feasible`, :mod:`suspenv.runs.quality`)."""
    out = np.asarray(ok, bool).copy()
    g = np.asarray(constraints, float)
    if g.size:
        out &= np.nan_to_num(g, nan=1.0).max(axis=1) <= 0
    return out


def check_scales(
    scales: Sequence[float] | np.ndarray, k: int, what: str = "constraint", owner: str = ""
) -> np.ndarray:
    """``scales`` as a (k,) float array, or a ValidationError (prefixed by ``owner``)
    naming the rule and value: one scale per ``what`` (constraint, objective), each
    finite and > 0."""
    s = np.asarray(scales, dtype=float).reshape(-1)
    if s.shape != (k,) or not (np.isfinite(s).all() and (s > 0).all()):
        raise ValidationError(
            f"{owner}{what} scales must be {k} finite numbers > 0 (one per {what}), but "
            f"got {np.asarray(scales).tolist()!r}"
        )
    return s
