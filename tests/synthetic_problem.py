"""A small identification problem with a known answer, for testing the study pipeline
(the tests name it ``synthetic_problem:SyntheticIdentification``).

Eight parameters, ten simulated metrics in four planted groups, each metric's objective
the mismatch |simulated - measured| to targets made by a known truth design:

======  =====================  ===============================================
group   depends on             metrics
======  =====================  ===============================================
A       stiffness_a            3 increasing functions of it (one in big units)
B       b1 + b2                3 increasing functions of the sum
C       c                      2 increasing functions
D       d1 + d2                2 increasing functions of the sum
none    spare_1, spare_2       nothing: not identifiable
======  =====================  ===============================================

So the truth is: 4 clusters of objectives; spare_1 and spare_2 are flat directions, and
so are b1 - b2 and d1 - d2 (only the sums are seen). A design with ``d1 + d2 > 1.8`` is
infeasible (constraint), and one with ``spare_2 > 0.98`` fails to evaluate (like a
linkage lock-up). Curves for the report: each group is a "test" whose measured curve
(truth plus a small hysteresis loop, loading then unloading branch) is plotted against
the model's. Units are nominal (this problem has no physics).
"""

from __future__ import annotations

import numpy as np

from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.options import number

GROUPS = {
    "A": ("a_gradient", "a_position", "a_force"),
    "B": ("b_gradient", "b_position", "b_cubic"),
    "C": ("c_gradient", "c_position"),
    "D": ("d_gradient", "d_position"),
}

TRUTH = {
    "stiffness_a": 6.5,
    "b1": 0.3,
    "b2": 0.45,
    "c": 140.0,
    "d1": 0.25,
    "d2": 0.6,
    "spare_1": 2.0,
    "spare_2": 0.5,
}


class SyntheticIdentification(Problem):
    """Recover a known design from mismatch objectives in four planted groups (test problem)."""

    name = "SyntheticIdentification"
    description = "known-answer identification problem with planted objective groups"

    def __init__(self, hysteresis: float = 0.05):
        """``hysteresis``: half-width of the measured loops (nominal units), finite, >= 0."""
        self.hysteresis = number(self.name, "hysteresis", hysteresis, lo=0.0)
        self.space = DesignSpace(
            [
                Parameter("stiffness_a", 1.0, 10.0, "N/mm", default=4.0),
                Parameter("b1", 0.0, 1.0, "mm", default=0.5),
                Parameter("b2", 0.0, 1.0, "mm", default=0.5),
                Parameter("c", 100.0, 200.0, "N/mm", default=150.0),
                Parameter("d1", 0.0, 1.0, "deg", default=0.5),
                Parameter("d2", 0.0, 1.0, "deg", default=0.5),
                Parameter("spare_1", 0.0, 5.0, "mm"),
                Parameter("spare_2", 0.0, 1.0, "mm"),
            ]
        )
        self.objective_names = tuple(n for names in GROUPS.values() for n in names)
        self.constraint_names = ("d_sum_limit",)
        self._target = self.metrics(self.truth_design()[None, :])[0]

    # ----------------------------------------------------------------- hooks
    def truth_design(self) -> np.ndarray:
        """The design that made the measurements."""
        return self.space.from_dict(TRUTH)

    def initial_design(self) -> np.ndarray:
        """The initial model (the parameters' defaults)."""
        return self.space.reference()

    def metrics(self, X: np.ndarray) -> np.ndarray:
        """(n, 10) simulated metric values of physical designs X (n, 8)."""
        X = np.atleast_2d(X)
        a, b, c, d = X[:, 0], X[:, 1] + X[:, 2], X[:, 3], X[:, 4] + X[:, 5]
        return np.column_stack(
            [a, 2.0 * a + 1.0, 100.0 * a, b, 0.5 * b + 0.2, b**3, c / 100.0, np.sqrt(c), d, 3 * d]
        )

    def residuals(self, X: np.ndarray) -> np.ndarray:
        """(n, 10) signed simulated minus measured metric values."""
        return self.metrics(X) - self._target

    def curves(self, x: np.ndarray) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
        """Model curves of one design: per group, value = gradient * travel + position."""
        mtr = self.metrics(np.asarray(x, dtype=float)[None, :])[0]
        return self._curves(mtr, 0.0)

    def measured_curves(self) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
        """Measured curves: the truth's, with a hysteresis loop of half-width ``hysteresis``."""
        return self._curves(self._target, self.hysteresis)

    def _curves(self, mtr: np.ndarray, loop: float) -> dict:
        up = np.linspace(-40.0, 40.0, 31)
        s = np.concatenate([up, up[::-1]])
        branch = np.concatenate([np.full(31, loop), np.full(31, -loop)])
        out = {}
        col = 0
        for group, names in GROUPS.items():
            grad, pos = mtr[col], mtr[col + 1]
            out[f"test {group}"] = {"response": (s, grad * s / 40.0 + pos + branch)}
            col += len(names)
        return out

    # --------------------------------------------------------------- physics
    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        R = self.residuals(X)
        F = np.abs(R)
        G = (X[:, 4] + X[:, 5] - 1.8)[:, None]
        ok = X[:, 7] <= 0.98
        F[~ok] = np.nan
        G[~ok] = np.nan
        msgs = ["" if k else "LockupError: spare_2 > 0.98 locks the linkage" for k in ok]
        return EvaluationBatch(F, G, ok, msgs, {"residuals": np.where(ok[:, None], R, np.nan)})

    def config(self) -> dict:
        return {"hysteresis": self.hysteresis}
