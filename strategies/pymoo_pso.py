"""A plug-in wrapping a library optimiser: pymoo's particle swarm (PSO), one swarm per ask.

The pattern for any ask/tell library: build the library's optimiser on the unit cube,
hand its candidates out in ``_ask``, give it the scores in ``_tell``. Scores come from
:meth:`~suspenv.strategies.base.ScalarStrategy.fitness` (several objectives scalarised,
infeasible and failed designs ranked last), so the wrapper stays a few lines. Run it::

    suspenv suite run --strategies strategies/pymoo_pso.py:PymooPSO --seeds 1 2 3
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pymoo.algorithms.soo.nonconvex.pso import PSO
from pymoo.core.evaluator import Evaluator
from pymoo.core.problem import Problem
from pymoo.core.termination import NoTermination
from pymoo.problems.static import StaticProblem

from suspenv.core.options import integer
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import ScalarStrategy


class PymooPSO(ScalarStrategy):
    """Particle swarm optimisation (pymoo's PSO); option ``swarm_size`` (default 25)."""

    name = "pymoo_pso"
    option_names = ("swarm_size",)

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        swarm_size: int = 25,
        scalarizer: str = "weighted_sum",
        weights: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed, scalarizer, weights)
        self.swarm_size = integer(self.name, "swarm_size", swarm_size, lo=2)
        self._problem = Problem(n_var=self.dim, n_obj=1, xl=0.0, xu=1.0)
        self._pso = PSO(pop_size=self.swarm_size)
        self._pso.setup(self._problem, termination=NoTermination(), seed=self.seed)
        self._swarm: Any = None

    def _ask(self) -> np.ndarray:
        self._swarm = self._pso.ask()
        return np.clip(np.asarray(self._swarm.get("X"), dtype=float), 0.0, 1.0)

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        scores = self.fitness(batch).reshape(-1, 1)  # finite; lower is better
        Evaluator().eval(StaticProblem(self._problem, F=scores), self._swarm)
        self._pso.tell(infills=self._swarm)
