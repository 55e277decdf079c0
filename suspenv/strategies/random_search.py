"""Uniform random search in the unit cube: the baseline every strategy must beat."""

from __future__ import annotations

import numpy as np

from suspenv.core.options import integer
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import ScalarStrategy


class RandomSearch(ScalarStrategy):
    """Independent uniform samples, ``batch_size`` per ask; keeps the best seen.

    Options (checked at construction): batch_size, an integer >= 1 (default 50);
    scalarizer/weights for the best-so-far bookkeeping (see
    :class:`~suspenv.strategies.base.ScalarStrategy`). Samples do not depend on the
    results: failed evaluations change nothing but the best-so-far.
    """

    name = "random"
    description = "uniform random search (baseline)"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        batch_size: int = 50,
        scalarizer: str = "weighted_sum",
        weights: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed, scalarizer, weights)
        self.batch_size = integer(self.name, "batch_size", batch_size, lo=1)
        self._rng = np.random.default_rng(self.seed)
        self.best_u: np.ndarray | None = None
        self.best_f = np.inf

    def _ask(self) -> np.ndarray:
        return self._rng.uniform(0.0, 1.0, (self.batch_size, self.dim))

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        if batch.n_objectives == 1:
            f = np.where(batch.feasible, batch.objectives[:, 0], np.inf)
            i = int(np.argmin(f))
            if f[i] < self.best_f:
                self.best_f, self.best_u = float(f[i]), U[i].copy()
