"""Uniform random search in the unit cube: the baseline every strategy must beat."""

from __future__ import annotations

import numpy as np

from suspenv.core.options import integer
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import ScalarStrategy


class RandomSearch(ScalarStrategy):
    """Independent uniform samples, ``batch_size`` per ask.

    Options (checked at construction): batch_size, an integer >= 1 (default 50);
    scalarizer/weights, checked and recorded as by
    :class:`~suspenv.strategies.base.ScalarStrategy`. Samples do not depend on the
    results (the run keeps the best: :mod:`suspenv.runs.quality`).
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

    def _ask(self) -> np.ndarray:
        return self._rng.uniform(0.0, 1.0, (self.batch_size, self.dim))

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        pass
