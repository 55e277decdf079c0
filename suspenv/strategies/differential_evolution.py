"""Differential evolution (Storn and Price 1997) as ask/tell, one generation per batch.

``scipy.optimize.differential_evolution`` calls the objective itself, so it cannot be
driven by a loop that asks and tells; this module is a small implementation of the same
algorithm written from the published description (Storn and Price, J. Global Optim. 11,
1997) and scipy's documented defaults:

- population ``popsize * d`` members (scipy's ``popsize`` multiplier, default 15; at
  least 5 members here, so that distinct members can always be drawn), initialised by a
  Latin hypercube (``scipy.stats.qmc.LatinHypercube``) or uniformly;
- strategy ``best1bin`` (default): mutant ``b = x_best + F (x_r0 - x_r1)``; or
  ``rand1bin``: ``b = x_r0 + F (x_r1 - x_r2)``; ``r0, r1, r2`` distinct members other than
  the target ``i``;
- mutation ``F`` drawn from U[0.5, 1) once per generation (scipy's dithering, default
  ``(0.5, 1)``), or a fixed number;
- binomial crossover with recombination ``CR = 0.7``: each coordinate from the mutant
  with probability CR, one random coordinate always from the mutant;
- a trial coordinate outside [0, 1] is replaced by a uniform draw in [0, 1];
- ``updating="deferred"``: the whole trial population is one batch, and each trial
  replaces its target when it is at least as good (``<=``, Storn and Price keep the
  target unless the trial is better; ``<=`` lets the population move along plateaus and
  out of a region where every design fails);
- stop (:meth:`stop`): ``std(E) <= atol + tol * |mean(E)|`` over the population's values
  (``tol = 0.01``, ``atol = 0``, scipy's rule), once every member is feasible; or after
  ``maxiter`` generations (default 1000). scipy's final L-BFGS-B polish is not done (it
  would need gradients by finite differences, outside the seam).

Comparisons between a trial and its target follow Deb's feasibility rules (close to the
rule of Lampinen 2002 that scipy uses for constraints): a feasible design beats an
infeasible one, infeasible designs compare by total violation, and a failed design loses
to every design that did not fail (two failed designs: the trial replaces the target). Several
objectives are combined by ``weights`` (a weighted sum, the same for every generation, so
values of different generations compare). Randomness comes from
``numpy.random.default_rng(seed)`` only.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.stats import qmc

from suspenv.core.errors import ValidationError
from suspenv.core.options import choice, integer, number, numbers, optional
from suspenv.core.result import EvaluationBatch
from suspenv.core.scalarize import weighted_sum
from suspenv.strategies.base import Strategy

STRATEGIES = ("best1bin", "rand1bin")
INITS = ("latinhypercube", "random")
#: the fewest members a population has (three distinct members besides the target)
MIN_POPULATION = 5


class DifferentialEvolution(Strategy):
    """Differential evolution with scipy's defaults, one generation per ask.

    Options (checked at construction):
        popsize: population multiplier, an integer >= 1; the population has
            ``max(5, popsize * d)`` members (default 15, scipy's).
        mutation: F, a number in [0, 2), or a pair ``[lo, hi]`` with ``0 <= lo <= hi < 2``
            for dithering: F drawn from U[lo, hi) each generation (default (0.5, 1)).
        recombination: crossover probability CR in [0, 1] (default 0.7).
        strategy: "best1bin" (default) or "rand1bin".
        init: "latinhypercube" (default) or "random".
        maxiter: generations after the initial population before :meth:`stop` says so, an
            integer >= 0 (default 1000).
        tol, atol: convergence tolerances, finite numbers >= 0 (defaults 0.01 and 0).
        weights: one finite number per objective; the value compared is
            ``sum_j weights[j] * f_j`` (default all 1).
    """

    name = "de"
    description = "differential evolution (Storn & Price), scipy's defaults, one generation/batch"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        popsize: int = 15,
        mutation: float | tuple[float, float] | list[float] = (0.5, 1.0),
        recombination: float = 0.7,
        strategy: str = "best1bin",
        init: str = "latinhypercube",
        maxiter: int = 1000,
        tol: float = 0.01,
        atol: float = 0.0,
        weights: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        self.popsize = integer(owner, "popsize", popsize, lo=1)
        self.mutation = _mutation(owner, mutation)
        self.recombination = number(owner, "recombination", recombination, lo=0.0, hi=1.0)
        self.strategy = choice(owner, "strategy", strategy, STRATEGIES)
        self.init = choice(owner, "init", init, INITS)
        self.maxiter = integer(owner, "maxiter", maxiter, lo=0)
        self.tol = number(owner, "tol", tol, lo=0.0)
        self.atol = number(owner, "atol", atol, lo=0.0)
        self.weights = optional(numbers, owner, "weights", weights, self.n_objectives)
        self.population_size = max(MIN_POPULATION, self.popsize * self.dim)
        self._rng = np.random.default_rng(self.seed)
        #: the population (S, d) and, per member, its class (0 feasible, 1 infeasible,
        #: 2 failed) and value (objective for class 0, violation for class 1)
        self.population = np.empty((0, self.dim))
        self._rank = np.empty(0, dtype=int)
        self._value = np.empty(0)
        self.generation = 0  # generations told after the initial population

    # ------------------------------------------------------------------ the seam
    def _ask(self) -> np.ndarray:
        S = self.population_size
        if not len(self.population):
            if self.init == "latinhypercube":
                return qmc.LatinHypercube(d=self.dim, rng=self._rng).random(S)
            return self._rng.uniform(0.0, 1.0, (S, self.dim))
        F = self.mutation
        if isinstance(F, tuple):
            F = float(self._rng.uniform(F[0], F[1]))
        best = self.population[self.best_index]
        k = 2 if self.strategy == "best1bin" else 3  # members drawn besides the target
        trial = np.empty_like(self.population)
        for i in range(S):
            r = self._rng.choice(S - 1, size=k, replace=False)
            r[r >= i] += 1  # distinct members other than the target
            x = self.population[r]
            if self.strategy == "best1bin":
                mutant = best + F * (x[0] - x[1])
            else:
                mutant = x[0] + F * (x[1] - x[2])
            cross = self._rng.random(self.dim) < self.recombination
            cross[self._rng.integers(self.dim)] = True
            trial[i] = np.where(cross, mutant, self.population[i])
        outside = (trial < 0.0) | (trial > 1.0)
        trial[outside] = self._rng.uniform(0.0, 1.0, int(outside.sum()))
        return trial

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        rank, value = self._classify(batch)
        if not len(self.population):
            self.population, self._rank, self._value = U.copy(), rank, value
            return
        better = (rank < self._rank) | ((rank == self._rank) & (value <= self._value))
        self.population[better] = U[better]
        self._rank[better] = rank[better]
        self._value[better] = value[better]
        self.generation += 1

    def _classify(self, batch: EvaluationBatch) -> tuple[np.ndarray, np.ndarray]:
        """(class, value) per row: 0 feasible (value: weighted objectives), 1 infeasible
        (value: total violation), 2 failed (value 0)."""
        ok = batch.rankable
        f = weighted_sum(np.nan_to_num(batch.objectives), self.weights)
        v = np.where(ok, np.nan_to_num(batch.violation, nan=np.inf), 0.0)
        rank = np.where(~ok, 2, np.where(v > 0, 1, 0))
        value = np.where(rank == 0, f, np.where(rank == 1, v, 0.0))
        return rank.astype(int), value.astype(float)

    def stop(self) -> str | None:
        if not len(self.population) or self._pending is not None:
            return None
        if self.generation >= self.maxiter:
            return f"de: maxiter={self.maxiter} generations done"
        if np.all(self._rank == 0):
            E = self._value
            spread, mean = float(np.std(E)), float(np.mean(E))
            if spread <= self.atol + self.tol * abs(mean):
                return (
                    f"de: converged after {self.generation} generations: std(E)={spread:.3g} "
                    f"<= atol + tol * |mean(E)| = {self.atol:g} + {self.tol:g} * {abs(mean):.3g}"
                )
        return None

    # ------------------------------------------------------------------- results
    @property
    def best_index(self) -> int:
        """Index of the best member: feasible first, then least violation, failed last."""
        return int(np.lexsort((self._value, self._rank))[0])

    @property
    def population_energies(self) -> np.ndarray:
        """The weighted objective of each member (NaN for infeasible and failed ones)."""
        return np.where(self._rank == 0, self._value, np.nan)

    @property
    def best_value(self) -> float:
        """The weighted objective of the best member (NaN unless it is feasible)."""
        i = self.best_index
        return float(self._value[i]) if self._rank[i] == 0 else float("nan")

    def options(self) -> dict[str, Any]:
        mutation = list(self.mutation) if isinstance(self.mutation, tuple) else self.mutation
        return {**super().options(), "mutation": mutation}  # a range as a list, as written


def _mutation(owner: str, value: Any) -> float | tuple[float, float]:
    """F: a number in [0, 2), or a pair (lo, hi) with 0 <= lo <= hi < 2 (dithering)."""
    if isinstance(value, list | tuple) or getattr(value, "ndim", None) == 1:
        lo, hi = numbers(owner, "mutation", value, 2, lo=0.0, hi=2.0, hi_open=True)
        if lo > hi:
            raise ValidationError(
                f"{owner}: `mutation[0] <= mutation[1]` must hold for dithering, but got "
                f"mutation={[lo, hi]!r}"
            )
        return (lo, hi)
    return number(owner, "mutation", value, lo=0.0, hi=2.0, hi_open=True)
