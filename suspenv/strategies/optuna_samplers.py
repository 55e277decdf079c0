"""optuna's samplers behind the ask/tell seam: TPE, CMA-ES, NSGA-III and GP.

One strategy per sampler, registered as ``optuna_tpe``, ``optuna_cmaes``, ``optuna_nsga3``
and ``optuna_gp`` (NSGA-II over optuna is ``nsga2``, :mod:`suspenv.strategies.nsga2`). They
share the machinery of :class:`OptunaSampler`:

- The study's parameters are the problem's design variables by name, with distributions of
  their bounds, and its metric names the objectives' (:meth:`OptunaSampler.bind_problem`,
  which a run calls; :class:`~suspenv.strategies.nsga2.StudyDesign`); unbound, ``u0 ..
  u{d-1}`` in [0, 1]. The strategy asks and is told unit-cube designs either way.
- Each :meth:`ask` asks ``batch_size`` trials of an in-memory study, one after the other;
  :meth:`tell` tells them in the same order. Model-based samplers (TPE, GP) ask one trial
  per batch by default: each trial is then chosen from every result before it, which is
  what they are for (expensive evaluations). A larger batch keeps parallel workers busy;
  the trials of a batch are then chosen while the earlier ones are still running (TPE:
  optuna's constant liar; GP: optuna's q-batch acquisition over running trials).
  Population samplers (CMA-ES, NSGA-III) ask one whole generation per batch, as ``nsga2``.
- Seeded: the sampler takes ``seed``; nothing reads the clock or numpy's global generator,
  so a strategy rebuilt with the same seed and options and told the same results asks the
  same designs (resume replays a run this way).
- Several objectives are minimised together where the sampler supports them (TPE, NSGA-III,
  GP); optuna's CMA-ES takes one value, the weighted sum of the objectives (``weights``).
- Constraints (feasible when every value <= 0), divided by the problem's constraint scales
  (:attr:`EvaluationBatch.scaled_constraints`), go through optuna's constraint mechanism
  (``Trial.set_constraint`` in optuna >= 5, ``constraints_func`` before) for TPE, NSGA-III
  and GP. optuna's CMA-ES ignores constraints, so ``optuna_cmaes`` tells an infeasible
  design the penalty of :func:`suspenv.strategies.extras.told_losses` instead (CMA-ES only
  ranks the values of a generation: infeasible designs rank after every feasible one, by
  violation).
- A failed design (``ok`` False, or a non-finite objective) is told as ``TrialState.FAIL``:
  it takes no part in any model or selection.

Optional packages (checked when the strategy is built; a missing one is a
:class:`~suspenv.strategies.extras.MissingExtraError` naming the pip extra):
``optuna_cmaes`` needs ``cmaes`` (extra ``optuna-cmaes``), ``optuna_gp`` needs ``torch``
(extra ``optuna-gp``; several GB, never installed by default) and scipy (a core
dependency). TPE and NSGA-III need nothing beyond optuna.
"""

from __future__ import annotations

import logging
from typing import Any, ClassVar

import numpy as np
import optuna

from suspenv.core.options import flag, integer, number, numbers, optional
from suspenv.core.result import EvaluationBatch
from suspenv.core.scalarize import weighted_sum
from suspenv.strategies.base import Strategy, popsize_option
from suspenv.strategies.extras import require, told_losses
from suspenv.strategies.nsga2 import StudyDesign, constraints_func, quiet, tell_trials


class OptunaSampler(Strategy):
    """Shared machinery of the optuna sampler adapters (not registered itself).

    Subclasses build their sampler and call :meth:`_setup`; this class asks ``batch_size``
    trials per ask, tells results, constraints and failures, and records the options.
    """

    name = "optuna"
    #: the sampler handles constraints itself (through optuna's constraint mechanism)
    native_constraints: ClassVar[bool] = True

    def _setup(self, sampler: optuna.samplers.BaseSampler, n_values: int, batch_size: int) -> None:
        optuna.logging.set_verbosity(logging.WARNING)
        self.batch_size = batch_size
        self.sampler = sampler
        self.study = optuna.create_study(
            sampler=sampler,
            study_name=f"suspenv-{self.name}-{self.seed}",
            directions=["minimize"] * n_values,
        )
        self.design = StudyDesign(self.dim)
        self._trials: list[optuna.trial.Trial] = []

    def _ask(self) -> np.ndarray:
        with quiet():
            self._trials = [self.study.ask(self.design.dists) for _ in range(self.batch_size)]
        return self.design.unit(self._trials)

    def bind_problem(self, problem: Any) -> None:
        """Name the study's parameters and metrics after ``problem`` (before the first
        ask; :class:`~suspenv.strategies.nsga2.StudyDesign`)."""
        if self.study.trials:
            raise RuntimeError(f"{self.name}: bind_problem() must come before the first ask()")
        self.design.bind(problem)
        self.design.name_metrics(self.study)

    def _values(self, batch: EvaluationBatch) -> np.ndarray:
        """Values told to optuna, (n, directions); rows of failed designs are not used."""
        return np.asarray(batch.objectives, dtype=float)

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        constrained = bool(self.n_constraints) and self.native_constraints
        with quiet():
            tell_trials(
                self.study, list(enumerate(self._trials)), self._values(batch), batch, constrained
            )
        self._trials = []


class OptunaTPE(OptunaSampler):
    """Tree-structured Parzen estimator (Bergstra et al. 2011), optuna's ``TPESampler``.

    Options (checked at construction):
        batch_size: trials per ask, an integer >= 1 (default 1: each trial is chosen from
            every result before it; set it to the number of parallel workers to keep them
            busy, the pending trials are then handled by optuna's constant liar).
        n_startup_trials: random trials before TPE starts, an integer >= 0 (default 10).
        n_ei_candidates: candidates scored per trial, an integer >= 1 (default 24).
        multivariate: True for the multivariate TPE, False for the independent one, None
            for optuna's default (multivariate with one objective, independent with
            several).

    Several objectives: optuna's multi-objective TPE (MOTPE). Constraints: optuna's
    constrained TPE (c-TPE).
    """

    name = "optuna_tpe"
    description = "TPE (optuna), several objectives and constraints supported"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        batch_size: int = 1,
        n_startup_trials: int = 10,
        n_ei_candidates: int = 24,
        multivariate: bool | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        batch = integer(owner, "batch_size", batch_size, lo=1)
        self.n_startup_trials = integer(owner, "n_startup_trials", n_startup_trials, lo=0)
        self.n_ei_candidates = integer(owner, "n_ei_candidates", n_ei_candidates, lo=1)
        self.multivariate = flag(owner, "multivariate", multivariate, allow_none=True)
        with quiet():
            sampler = optuna.samplers.TPESampler(
                n_startup_trials=self.n_startup_trials,
                n_ei_candidates=self.n_ei_candidates,
                multivariate=self.multivariate,
                constant_liar=True,
                seed=self.seed,
                constraints_func=constraints_func(self.n_constraints),
            )
        self._setup(sampler, self.n_objectives, batch)


class OptunaCMAES(OptunaSampler):
    """CMA-ES (Hansen), optuna's ``CmaEsSampler`` over the ``cmaes`` package; one
    generation per ask.

    Options (checked at construction):
        popsize: population size lambda, an integer >= 2 (default 4 + floor(3 ln d), as
            pycma); every ask is one generation of ``popsize`` trials.
        n_startup_trials: trials that must complete before CMA-ES starts, an integer >= 0
            (default 0). The first batch is always drawn at random by optuna (CMA-ES starts
            once the search space is known from a completed trial), from the centre of the
            box with step size 1/6 of it.
        lr_adapt: learning-rate adaptation for multimodal and noisy problems (Nomura et al.
            2023), a bool (default False).
        weights: the value told is ``sum_j weights[j] * f_j``, one finite number per
            objective (default all 1); optuna's CMA-ES takes a single objective.

    Constraints are folded into the value (infeasible designs rank after every feasible
    one, by violation), since optuna's CMA-ES ignores them. A failed design is a failed
    trial; a generation counts only completed trials, so failures make optuna ask more of
    the same generation. For IPOP restarts, ``x0`` and ``sigma0`` use ``cmaes`` (pycma).
    """

    name = "optuna_cmaes"
    description = "CMA-ES (optuna + cmaes), one generation per batch; needs suspenv[optuna-cmaes]"
    native_constraints = False

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        popsize: int | None = None,
        n_startup_trials: int = 0,
        lr_adapt: bool = False,
        weights: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        self.popsize = popsize_option(owner, popsize, self.dim)
        self.n_startup_trials = integer(owner, "n_startup_trials", n_startup_trials, lo=0)
        self.lr_adapt = bool(flag(owner, "lr_adapt", lr_adapt))
        self.weights = optional(numbers, owner, "weights", weights, self.n_objectives)
        require(owner, "cmaes", "optuna-cmaes")
        with quiet():
            sampler = optuna.samplers.CmaEsSampler(
                popsize=self.popsize,
                n_startup_trials=self.n_startup_trials,
                lr_adapt=self.lr_adapt,
                warn_independent_sampling=False,
                seed=self.seed,
            )
        self._setup(sampler, 1, self.popsize)

    def _values(self, batch: EvaluationBatch) -> np.ndarray:
        ok = batch.rankable
        f = weighted_sum(np.nan_to_num(batch.objectives), self.weights, valid=ok)
        scalar = EvaluationBatch(
            f[:, None],
            batch.constraints,
            ok,
            batch.messages,
            constraint_scales=batch.constraint_scales,
        )
        return told_losses(scalar)


class OptunaNSGA3(OptunaSampler):
    """NSGA-III (Deb and Jain 2014), optuna's ``NSGAIIISampler``; one generation per ask.

    Options (checked at construction):
        population_size: designs per generation, an integer >= 2 (default 50).
        crossover_prob, swapping_prob: probabilities in [0, 1] (defaults 0.9 and 0.5).
        mutation_prob: probability in [0, 1], or None for optuna's default 1 / d.
        dividing_parameter: divisions of each objective axis for the structured reference
            points (Das and Dennis), an integer >= 1 (default 3).

    NSGA-III keeps a spread of solutions along reference directions: meant for three or
    more objectives, where NSGA-II's crowding distance loses its grip. optuna counts only
    completed trials towards a generation, so a generation in which every design fails
    breeds the next batch from the same parents.
    """

    name = "optuna_nsga3"
    description = "NSGA-III (optuna), one generation per batch, constraints supported"

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
        dividing_parameter: int = 3,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        self.population_size = integer(owner, "population_size", population_size, lo=2)
        self.crossover_prob = number(owner, "crossover_prob", crossover_prob, lo=0.0, hi=1.0)
        self.mutation_prob = optional(number, owner, "mutation_prob", mutation_prob, lo=0.0, hi=1.0)
        self.swapping_prob = number(owner, "swapping_prob", swapping_prob, lo=0.0, hi=1.0)
        self.dividing_parameter = integer(owner, "dividing_parameter", dividing_parameter, lo=1)
        with quiet():
            sampler = optuna.samplers.NSGAIIISampler(
                population_size=self.population_size,
                crossover_prob=self.crossover_prob,
                mutation_prob=self.mutation_prob,
                swapping_prob=self.swapping_prob,
                dividing_parameter=self.dividing_parameter,
                seed=self.seed,
                constraints_func=constraints_func(self.n_constraints),
            )
        self._setup(sampler, self.n_objectives, self.population_size)


class OptunaGP(OptunaSampler):
    """Gaussian-process Bayesian optimisation, optuna's ``GPSampler`` (needs torch).

    Options (checked at construction):
        batch_size: trials per ask, an integer >= 1 (default 1: each trial maximises the
            acquisition given every result before it; a larger batch uses optuna's q-batch
            acquisition over the trials still running).
        n_startup_trials: random trials before the GP is fitted, an integer >= 0
            (default 10).
        deterministic_objective: True when the objectives carry no noise (the GP then fits
            no noise term), a bool (default False).

    Acquisition (optuna's choice): log EI for one objective, log EHVI for several; with
    constraints, times the probability of feasibility. Fitting costs grow with the cube of
    the number of trials: meant for a few hundred evaluations.
    """

    name = "optuna_gp"
    description = "GP Bayesian optimisation (optuna + torch); needs suspenv[optuna-gp]"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        batch_size: int = 1,
        n_startup_trials: int = 10,
        deterministic_objective: bool = False,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        batch = integer(owner, "batch_size", batch_size, lo=1)
        self.n_startup_trials = integer(owner, "n_startup_trials", n_startup_trials, lo=0)
        self.deterministic_objective = bool(
            flag(owner, "deterministic_objective", deterministic_objective)
        )
        require(owner, "torch", "optuna-gp")
        with quiet():
            sampler = optuna.samplers.GPSampler(
                n_startup_trials=self.n_startup_trials,
                deterministic_objective=self.deterministic_objective,
                seed=self.seed,
                constraints_func=constraints_func(self.n_constraints),
            )
        self._setup(sampler, self.n_objectives, batch)
