"""Latin hypercube design of experiments (``scipy.stats.qmc.LatinHypercube``).

One design of ``n_samples`` points is drawn at construction and handed out in batches of
``batch_size``; the strategy stops when every point has been asked.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

from suspenv.core.options import choice, integer, optional
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import Strategy

#: scipy's Latin hypercube optimisations (``scipy.stats.qmc.LatinHypercube``)
OPTIMIZATIONS = ("random-cd", "lloyd")


class LatinHypercube(Strategy):
    """A seeded Latin hypercube sample of the unit cube.

    Options (checked at construction):
        n_samples: size of the design, an integer >= 1 (default 500, as in Tey et al. 2014).
        batch_size: points per ask, an integer >= 1 (default 50).
        optimization: scipy's LHS optimisation ("random-cd", "lloyd") or None (default).

    The design does not depend on the results: failed evaluations change nothing.
    """

    name = "lhs"
    description = "Latin hypercube design of experiments (scipy.stats.qmc)"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        n_samples: int = 500,
        batch_size: int = 50,
        optimization: str | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        self.n_samples = integer(self.name, "n_samples", n_samples, lo=1)
        self.batch_size = integer(self.name, "batch_size", batch_size, lo=1)
        self.optimization = optional(choice, self.name, "optimization", optimization, OPTIMIZATIONS)
        sampler = qmc.LatinHypercube(d=self.dim, optimization=self.optimization, rng=self.seed)
        self.design = sampler.random(self.n_samples)
        self._next = 0

    def _ask(self) -> np.ndarray:
        if self._next >= self.n_samples:
            raise RuntimeError(f"lhs: all {self.n_samples} samples were already asked")
        stop = min(self._next + self.batch_size, self.n_samples)
        U = self.design[self._next : stop]
        self._next = stop
        return U

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        pass

    def stop(self) -> str | None:
        if self._next >= self.n_samples and self._pending is None:
            return f"lhs: all {self.n_samples} samples evaluated"
        return None
