"""NSGA-II over optuna's ask/tell interface, one whole generation per ask.

optuna's ``NSGAIISampler`` assigns each new trial to a generation and breeds it from the
*completed* trials of the previous one. Asking more than one population before telling
would breed from nothing and silently degrade to random sampling, so :meth:`ask` always
asks exactly ``population_size`` trials and the base class refuses a second ask before
the tell.

Constraints go through optuna's constraint mechanism (``Trial.set_constraint`` in optuna
>= 5, ``constraints_func`` before; feasible when
every value <= 0, the same convention as suspenv). Failed evaluations are told as
``TrialState.FAIL`` and take no part in selection. Storage is in memory by default; pass
an optuna storage URL (e.g. ``sqlite:///study.db`` or an RDB/journal URL) and a
``study_name`` to share a study between many workers.
"""

from __future__ import annotations

import logging
import warnings
from typing import Any

import numpy as np
import optuna
from optuna.distributions import BaseDistribution, FloatDistribution
from optuna.trial import TrialState

from suspenv.core.options import integer, number, text
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import Strategy

_CONSTRAINTS_KEY = "suspenv_constraints"
#: optuna >= 5 takes constraints per trial (``Trial.set_constraint``); older: constraints_func
_PER_TRIAL_CONSTRAINTS = hasattr(optuna.trial.Trial, "set_constraint")


def _constraints_of(trial: optuna.trial.FrozenTrial) -> list[float]:
    return list(trial.user_attrs.get(_CONSTRAINTS_KEY, []))


class NSGA2(Strategy):
    """Non-dominated sorting genetic algorithm II (Deb et al. 2002), optuna backend.

    Options (checked at construction):
        population_size: designs per generation, an integer >= 2 (default 50).
        crossover_prob, mutation_prob, swapping_prob: probabilities in [0, 1] passed to
            optuna's sampler (mutation_prob None: optuna's default, 1 / d).
        storage: optuna storage URL (a non-empty string), or None for in-memory (default).
        study_name: study name in the storage (default "suspenv-nsga2-<seed>").

    A generation in which every design fails does not replace the population: optuna
    counts only completed trials towards a generation, so the next batch is bred from the
    same parents (failed trials take no part in selection).
    """

    name = "nsga2"
    description = "NSGA-II (optuna), one generation per batch, constraints supported"
    multi_objective = True

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        population_size: int = 50,
        crossover_prob: float = 0.9,
        mutation_prob: float | None = None,
        swapping_prob: float = 0.5,
        storage: str | None = None,
        study_name: str | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        self.population_size = integer(owner, "population_size", population_size, lo=2)
        self.crossover_prob = number(owner, "crossover_prob", crossover_prob, lo=0.0, hi=1.0)
        self.mutation_prob = (
            None
            if mutation_prob is None
            else number(owner, "mutation_prob", mutation_prob, lo=0.0, hi=1.0)
        )
        self.swapping_prob = number(owner, "swapping_prob", swapping_prob, lo=0.0, hi=1.0)
        self.storage = None if storage is None else text(owner, "storage", storage)
        self.study_name = (
            f"suspenv-nsga2-{self.seed}"
            if study_name is None
            else text(owner, "study_name", study_name)
        )
        optuna.logging.set_verbosity(logging.WARNING)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            sampler = optuna.samplers.NSGAIISampler(
                population_size=self.population_size,
                crossover_prob=self.crossover_prob,
                mutation_prob=self.mutation_prob,
                swapping_prob=self.swapping_prob,
                seed=self.seed,
                constraints_func=(
                    _constraints_of if self.n_constraints and not _PER_TRIAL_CONSTRAINTS else None
                ),
            )
        self.study = optuna.create_study(
            storage=self.storage,
            sampler=sampler,
            study_name=self.study_name,
            directions=["minimize"] * self.n_objectives,
            load_if_exists=self.storage is not None,
        )
        self._dists: dict[str, BaseDistribution] = {
            f"u{i}": FloatDistribution(0.0, 1.0) for i in range(self.dim)
        }
        self._trials: list[optuna.trial.Trial] = []

    def _ask(self) -> np.ndarray:
        self._trials = [self.study.ask(self._dists) for _ in range(self.population_size)]
        return np.array([[t.params[f"u{i}"] for i in range(self.dim)] for t in self._trials])

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        for i, trial in enumerate(self._trials):
            if not batch.ok[i] or not np.isfinite(batch.objectives[i]).all():
                self.study.tell(trial, state=TrialState.FAIL)
                continue
            if self.n_constraints and _PER_TRIAL_CONSTRAINTS:
                for j, g in enumerate(batch.constraints[i]):
                    trial.set_constraint(f"g{j}", float(g))
            elif self.n_constraints:
                trial.set_user_attr(_CONSTRAINTS_KEY, batch.constraints[i].tolist())
            self.study.tell(trial, batch.objectives[i].tolist())
        self._trials = []

    def options(self) -> dict[str, Any]:
        return {
            "population_size": self.population_size,
            "crossover_prob": self.crossover_prob,
            "mutation_prob": self.mutation_prob,
            "swapping_prob": self.swapping_prob,
            "storage": self.storage,
            "study_name": self.study_name,
        }
