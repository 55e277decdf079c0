"""CMA-ES over :mod:`cma` (pycma), in the unit cube, with optional IPOP restarts.

- Seeded, never from the clock: pycma draws from a private ``numpy.random.Generator``
  (option ``randn``) so two strategies in one process do not share a random stream.
- Bounds [0, 1]^d are handled by pycma's ``BoundTransform``: every asked design is
  already inside the box, so the whole asked population is told unchanged.
- Several objectives are scalarised per generation (``scalarizer="rank_sum"`` gives Tey
  et al.'s dynamic rank-sum); infeasible and failed designs are ranked last.
- ``restarts=k`` enables IPOP-CMA-ES: when pycma meets a stop criterion, a fresh run
  starts from a seeded random point with the population multiplied by ``incpopsize``.
- A generation in which every design fails is not told to pycma (its fitness would be
  flat, and a flat fitness ends pycma at once); the step size is doubled instead (up to
  1, the whole box) and the next generation is asked from the same mean. After
  ``max_failed_generations`` such generations in a row the run restarts (when restarts
  are left) or stops with that reason. ask/tell stay a function of the seed and the told
  results, so a run replayed against its archive asks the same designs.

Option rules (checked at construction): ``popsize >= 2``, ``0 < sigma0 <= 1``, ``x0`` d
numbers in [0, 1], ``restarts >= 0``, ``incpopsize >= 1``, ``tolfun >= 0``, ``tolx >= 0``,
``max_failed_generations >= 1``; integers where a count is meant, finite numbers
everywhere; ``scalarizer`` and ``weights`` as in
:class:`~suspenv.strategies.base.ScalarStrategy`.
"""

from __future__ import annotations

from typing import Any

import cma
import numpy as np

from suspenv.core.options import integer, number, numbers, optional
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import ScalarStrategy, popsize_option

#: step-size factor after a generation in which every design failed, and the step size
#: (unit-cube coordinates) it never widens beyond: 1 spans the whole box
FAILED_SIGMA_FACTOR = 2.0
FAILED_SIGMA_CAP = 1.0


class CMAES(ScalarStrategy):
    """Covariance matrix adaptation evolution strategy (Hansen), pycma backend.

    Options:
        popsize: population size lambda (default pycma's 4 + 3 ln d).
        sigma0: initial step size in unit-cube coordinates (default 0.25).
        x0: initial mean in the unit cube, list of d values (default the centre 0.5).
        restarts: number of IPOP restarts (default 0).
        incpopsize: population growth factor per restart (default 2).
        tolfun, tolx: pycma stop tolerances (defaults 1e-11).
        max_failed_generations: generations in a row in which every design fails before
            the run stops (or restarts, when ``restarts`` are left); default 10.
        scalarizer, weights: see :class:`~suspenv.strategies.base.ScalarStrategy`.
    """

    name = "cmaes"
    description = "CMA-ES (pycma), bounds by BoundTransform, optional IPOP restarts"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        popsize: int | None = None,
        sigma0: float = 0.25,
        x0: list[float] | None = None,
        restarts: int = 0,
        incpopsize: float = 2.0,
        tolfun: float = 1e-11,
        tolx: float = 1e-11,
        max_failed_generations: int = 10,
        scalarizer: str = "weighted_sum",
        weights: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed, scalarizer, weights)
        owner = self.name
        self.popsize = popsize_option(owner, popsize, self.dim)
        self.sigma0 = number(owner, "sigma0", sigma0, lo=0.0, hi=1.0, lo_open=True)
        self.x0 = optional(numbers, owner, "x0", x0, self.dim, lo=0.0, hi=1.0)
        self.restarts = integer(owner, "restarts", restarts, lo=0)
        self.incpopsize = number(owner, "incpopsize", incpopsize, lo=1.0)
        self.tolfun = number(owner, "tolfun", tolfun, lo=0.0)
        self.tolx = number(owner, "tolx", tolx, lo=0.0)
        self.max_failed_generations = integer(
            owner, "max_failed_generations", max_failed_generations, lo=1
        )
        self._rng = np.random.default_rng(self.seed)
        self.restart_count = 0
        self.history: list[dict[str, Any]] = []
        #: generations in a row (and in all) in which every design failed
        self.failed_generations = 0
        self.failed_generations_total = 0
        self.last_failure = ""
        self._es = self._new_es(self.x0 or [0.5] * self.dim, self.popsize)

    def _new_es(self, x0: list[float], popsize: int) -> cma.CMAEvolutionStrategy:
        rng = self._rng
        opts = {
            "popsize": popsize,
            "bounds": [0.0, 1.0],
            "seed": float("nan"),  # "do nothing": randomness comes from `randn` below
            "randn": lambda *shape: rng.standard_normal(shape),
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
            "tolfun": self.tolfun,
            "tolx": self.tolx,
        }
        return cma.CMAEvolutionStrategy(list(x0), self.sigma0, opts)

    def _ask(self) -> np.ndarray:
        return np.clip(np.asarray(self._es.ask(), dtype=float), 0.0, 1.0)

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        ok = batch.rankable
        if not ok.any():
            self._tell_all_failed(batch)
            return
        self.failed_generations = 0
        f = self.fitness(batch)
        self._es.tell(list(U), f.tolist())
        if self._es.stop() and self.restart_count < self.restarts:
            self._restart(dict(self._es.stop()), len(batch))

    def _tell_all_failed(self, batch: EvaluationBatch) -> None:
        """A generation in which every design failed: pycma is not told (a flat fitness
        would end it); the step size is widened instead, so the next generation looks
        further from the mean. After ``max_failed_generations`` such generations in a
        row, an IPOP restart when one is left, else :meth:`stop` says so."""
        self.failed_generations += 1
        self.failed_generations_total += 1
        self.last_failure = next((m for m in batch.messages if m), "no message")
        sigma = float(self._es.sigma)
        self._es.sigma = max(sigma, min(FAILED_SIGMA_FACTOR * sigma, FAILED_SIGMA_CAP))
        if (
            self.failed_generations >= self.max_failed_generations
            and self.restart_count < self.restarts
        ):
            self._restart({"max_failed_generations": self.max_failed_generations}, len(batch))
            self.failed_generations = 0

    def _restart(self, reasons: dict[str, Any], n_batch: int) -> None:
        """IPOP: a fresh pycma run from a seeded random point, population times
        ``incpopsize``."""
        self.history.append(
            {
                "restart": self.restart_count,
                "popsize": self.popsize,
                "stop": reasons,
                "evaluations": self.n_told + n_batch,
            }
        )
        self.restart_count += 1
        self.popsize = int(round(self.popsize * self.incpopsize))
        self._es = self._new_es(self._rng.uniform(0.0, 1.0, self.dim).tolist(), self.popsize)

    def stop(self) -> str | None:
        if self.failed_generations >= self.max_failed_generations:
            return (
                f"cmaes: every design failed in {self.failed_generations} consecutive "
                f"generations (max_failed_generations={self.max_failed_generations}; "
                f"after {self.restart_count} restart(s)); last failure: {self.last_failure}"
            )
        reasons = self._es.stop()
        if reasons:
            text = ", ".join(f"{k}={v}" for k, v in reasons.items())
            return f"cma: {text} (after {self.restart_count} restart(s))"
        return None

    @property
    def mean(self) -> np.ndarray:
        """Current distribution mean in the unit cube: pycma's mean passed through its bound
        transformation (a mean beyond a bound is reflected back into the box, as the designs
        sampled around it are; pycma's ``result.xfavorite``)."""
        es = self._es
        x = es.gp.pheno(es.mean, into_bounds=es.boundary_handler.repair)
        return np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
