"""NSGA-II over pymoo, vectorised per generation: the fast path for large populations.

optuna's NSGA-II (:mod:`suspenv.strategies.nsga2`) asks one trial at a time and scans the whole
study for each, so its cost grows with the square of the evaluations (30,000 evaluations
at population 500 take tens of minutes of sampler time). pymoo breeds and selects a whole
generation with array operations. Use ``nsga2`` for optuna storages shared by many
workers, ``pymoo_nsga2`` for large single-machine runs.

Conventions: designs live in the unit cube; constraints g <= 0 are passed to pymoo as
inequality constraints, divided by the problem's constraint scales
(:attr:`EvaluationBatch.scaled_constraints`), so pymoo's CV is the batch's violation.
Failed evaluations get a large finite objective value (:data:`.extras.FAILED_LOSS`,
dominated by every working design) and, on a constrained problem, one extra constraint
column (0 when ok, 1 when failed) so they are also infeasible; an unconstrained problem
stays unconstrained in pymoo (its constraint handling costs about 30 % of a generation's
bookkeeping). Either way a failure is never selected over a working design. Randomness
comes from pymoo's per-algorithm generator seeded with ``seed``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pymoo.algorithms.moo import nsga2 as _pymoo_nsga2
from pymoo.core.evaluator import Evaluator
from pymoo.core.problem import Problem as _PymooProblem
from pymoo.core.termination import NoTermination
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM
from pymoo.problems.static import StaticProblem

from suspenv.core.options import integer, number, positive
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import Strategy
from suspenv.strategies.extras import FAILED_LOSS

if TYPE_CHECKING:
    from pymoo.core.population import Population


class PymooNSGA2(Strategy):
    """NSGA-II (Deb et al. 2002), pymoo backend; one generation per ask.

    Options (checked at construction):
        population_size: designs per generation, an integer >= 2 (default 100).
        crossover_prob: SBX crossover probability in [0, 1] (default 0.9).
        crossover_eta, mutation_eta: distribution indices of SBX and polynomial mutation,
            finite and > 0 (defaults 15 and 20).

    A generation in which every design fails does not replace the population: failed
    designs are dominated (and infeasible on a constrained problem), and NSGA-II's
    survival (parents and offspring together, feasible and non-dominated first) keeps
    every parent that had succeeded.
    """

    name = "pymoo_nsga2"
    description = "NSGA-II (pymoo), vectorised per generation; fast for large populations"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        population_size: int = 100,
        crossover_prob: float = 0.9,
        crossover_eta: float = 15.0,
        mutation_eta: float = 20.0,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        self.population_size = integer(owner, "population_size", population_size, lo=2)
        self.crossover_prob = number(owner, "crossover_prob", crossover_prob, lo=0.0, hi=1.0)
        self.crossover_eta = positive(owner, "crossover_eta", crossover_eta)
        self.mutation_eta = positive(owner, "mutation_eta", mutation_eta)
        self._problem = _PymooProblem(
            n_var=self.dim,
            n_obj=self.n_objectives,
            n_ieq_constr=self.n_constraints + 1 if self.n_constraints else 0,
            xl=0.0,
            xu=1.0,
        )
        self._algorithm = _pymoo_nsga2.NSGA2(
            pop_size=self.population_size,
            crossover=SBX(prob=self.crossover_prob, eta=self.crossover_eta),
            mutation=PM(eta=self.mutation_eta),
        )
        self._algorithm.setup(
            self._problem, termination=NoTermination(), seed=self.seed, verbose=False
        )
        self._population: Population | None = None  # the generation between ask and tell

    def _ask(self) -> np.ndarray:
        population = self._algorithm.ask()
        self._population = population
        return np.clip(np.asarray(population.get("X"), dtype=float), 0.0, 1.0)

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        ok = batch.rankable
        F = np.where(ok[:, None], batch.objectives, FAILED_LOSS)
        if self.n_constraints:
            G = np.where(ok[:, None], np.nan_to_num(batch.scaled_constraints, nan=1.0), 1.0)
            G = np.column_stack([G, (~ok).astype(float)])
            static = StaticProblem(self._problem, F=F, G=G)
        else:
            static = StaticProblem(self._problem, F=F)
        Evaluator().eval(static, self._population)
        self._algorithm.tell(infills=self._population)
        self._population = None
