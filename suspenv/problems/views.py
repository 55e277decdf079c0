"""A view of a problem that exposes only some of its objectives (the kept ones)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import integer
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch


class ObjectiveSubset(Problem):
    """``base`` with only the objective columns ``keep`` (constraints unchanged).

    Failures are isolated by ``base.evaluate``; this view never raises for physics.
    """

    name = "ObjectiveSubset"
    description = "a problem restricted to some of its objectives"

    def __init__(self, base: Problem, keep: Sequence[int]):
        m = base.n_objectives
        if not isinstance(keep, list | tuple) and getattr(keep, "ndim", None) != 1:
            raise ValidationError(
                f"{self.name}: `keep` must be a list of objective indices, but got {keep!r}"
            )
        idx = [integer(self.name, f"keep[{j}]", i, lo=0, hi=m - 1) for j, i in enumerate(keep)]
        if not idx or len(set(idx)) != len(idx):
            raise ValidationError(
                f"{self.name}: `keep` must be distinct objective indices in [0, {m}), but got "
                f"{list(keep)}"
            )
        self.base = base
        self.keep = tuple(idx)
        self.name = f"{base.name}[{len(idx)} of {m} objectives]"
        self.space = base.space
        self.objective_names = tuple(base.objective_names[i] for i in idx)
        self.constraint_names = tuple(base.constraint_names)
        self.constraint_scales = tuple(base.constraint_scales)
        units = tuple(getattr(base, "objective_units", ()) or ())
        self.objective_units = tuple(units[i] for i in idx) if len(units) == m else ()

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        full = self.base.evaluate(X)
        return EvaluationBatch(
            full.objectives[:, list(self.keep)],
            full.constraints,
            full.ok,
            full.messages,
            full.extras,
        )

    def config(self) -> dict:
        return {"base": self.base.name, "keep": list(self.keep)}


#: names of the per-row extras a problem may return with the signed responses (n, m)
SIGNED_EXTRAS = ("residuals", "simulated")


class WithSignedResponses(Problem):
    """``base`` whose objectives are followed by its signed responses (2 m columns).

    The signed responses come from the batch's extras (``"residuals"``, or else
    ``"simulated"``: the simulated values; both give the same rank correlations because the
    measured targets are constants), so the design of experiments archives them for free.
    Where the base provides neither, the extra columns are NaN.
    """

    name = "WithSignedResponses"
    description = "a problem's objectives followed by its signed responses"

    def __init__(self, base: Problem):
        self.base = base
        self.name = base.name
        self.space = base.space
        m = base.n_objectives
        self.n_base = m
        signed = tuple(f"{n} (signed)" for n in base.objective_names)
        self.objective_names = tuple(base.objective_names) + signed
        self.informational_objectives = signed  # NaN where the base provides none
        self.constraint_names = tuple(base.constraint_names)
        self.constraint_scales = tuple(base.constraint_scales)
        units = tuple(getattr(base, "objective_units", ()) or ())
        self.objective_units = units + units if len(units) == m else ()

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        b = self.base.evaluate(X)
        n, m = len(b), self.n_base
        signed = np.full((n, m), np.nan)
        for key in SIGNED_EXTRAS:
            value = np.asarray(b.extras.get(key, np.empty(0)), dtype=float)
            if value.shape == (n, m):
                signed = value
                break
        signed = np.where(b.ok[:, None], signed, np.nan)
        return EvaluationBatch(
            np.hstack([b.objectives, signed]), b.constraints, b.ok, b.messages, b.extras
        )
