"""CMA-ES over :mod:`cma` (pycma), in the unit cube, with optional IPOP restarts.

- Seeded, never from the clock: pycma draws from a private ``numpy.random.Generator``
  (option ``randn``) so two strategies in one process do not share a random stream.
- Bounds [0, 1]^d are handled by pycma's ``BoundTransform``: every asked design is
  already inside the box, so the whole asked population is told unchanged.
- Several objectives are scalarised per generation (``scalarizer="rank_sum"`` gives Tey
  et al.'s dynamic rank-sum); infeasible and failed designs are ranked last.
- ``restarts=k`` enables IPOP-CMA-ES: when pycma meets a stop criterion, a fresh run
  starts from a seeded random point with the population multiplied by ``incpopsize``.
"""

from __future__ import annotations

import math
from typing import Any

import cma
import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import ScalarStrategy


class CMAES(ScalarStrategy):
    """Covariance matrix adaptation evolution strategy (Hansen), pycma backend.

    Options:
        popsize: population size lambda (default pycma's 4 + 3 ln d).
        sigma0: initial step size in unit-cube coordinates (default 0.25).
        x0: initial mean in the unit cube, list of d values (default the centre 0.5).
        restarts: number of IPOP restarts (default 0).
        incpopsize: population growth factor per restart (default 2).
        tolfun, tolx: pycma stop tolerances (defaults 1e-11).
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
        scalarizer: str = "weighted_sum",
        weights: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed, scalarizer, weights)
        if not 0 < sigma0 <= 1:
            raise ValidationError(f"cmaes: `0 < sigma0 <= 1` must hold, but got sigma0={sigma0}")
        if popsize is not None and int(popsize) < 2:
            raise ValidationError(f"cmaes: `popsize >= 2` must hold, but got popsize={popsize}")
        if int(restarts) < 0:
            raise ValidationError(f"cmaes: `restarts >= 0` must hold, but got {restarts}")
        if incpopsize < 1:
            raise ValidationError(f"cmaes: `incpopsize >= 1` must hold, but got {incpopsize}")
        if x0 is not None:
            x0 = [float(v) for v in x0]
            if len(x0) != self.dim or not all(0 <= v <= 1 for v in x0):
                raise ValidationError(
                    f"cmaes: `x0` must be {self.dim} values in [0, 1], but got {x0}"
                )
        self.popsize = int(popsize) if popsize else 4 + int(3 * math.log(self.dim))
        self.sigma0 = float(sigma0)
        self.x0 = x0
        self.restarts = int(restarts)
        self.incpopsize = float(incpopsize)
        self.tolfun, self.tolx = float(tolfun), float(tolx)
        self._rng = np.random.default_rng(self.seed)
        self.restart_count = 0
        self.history: list[dict[str, Any]] = []
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
        f = self.fitness(batch)
        self._es.tell(list(U), f.tolist())
        if self._es.stop() and self.restart_count < self.restarts:
            self.history.append(
                {
                    "restart": self.restart_count,
                    "popsize": self.popsize,
                    "stop": dict(self._es.stop()),
                    "evaluations": self.n_told + len(batch),
                }
            )
            self.restart_count += 1
            self.popsize = int(round(self.popsize * self.incpopsize))
            self._es = self._new_es(self._rng.uniform(0.0, 1.0, self.dim).tolist(), self.popsize)

    def stop(self) -> str | None:
        reasons = self._es.stop()
        if reasons:
            text = ", ".join(f"{k}={v}" for k, v in reasons.items())
            return f"cma: {text} (after {self.restart_count} restart(s))"
        return None

    @property
    def mean(self) -> np.ndarray:
        """Current distribution mean in the unit cube."""
        return np.clip(np.asarray(self._es.mean, dtype=float), 0.0, 1.0)

    def options(self) -> dict[str, Any]:
        return {
            **super().options(),
            "popsize": self.popsize,
            "sigma0": self.sigma0,
            "x0": self.x0,
            "restarts": self.restarts,
            "incpopsize": self.incpopsize,
            "tolfun": self.tolfun,
            "tolx": self.tolx,
        }
