"""NSGA-II over optuna's ask/tell interface, one whole generation per ask.

optuna's ``NSGAIISampler`` assigns each new trial to a generation and breeds it from the
*completed* trials of the previous one. Asking more than one population before telling
would breed from nothing and silently degrade to random sampling, so :meth:`ask` always
asks exactly ``population_size`` trials and the base class refuses a second ask before
the tell.

Constraints go through optuna's constraint mechanism (``Trial.set_constraint`` in optuna
>= 5, ``constraints_func`` before; feasible when
every value <= 0, the same convention as suspenv), each divided by the problem's constraint
scale (:attr:`EvaluationBatch.scaled_constraints`): optuna sums the violations.
Failed evaluations are told as ``TrialState.FAIL`` and take no part in selection.
Storage is in memory by default; pass an optuna storage URL (e.g. ``sqlite:///study.db``
or an RDB URL) and a ``study_name`` to keep the study (optuna-dashboard) or to share it
between many workers.

A run names the study after its problem (:meth:`NSGA2.bind_problem`, :class:`StudyDesign`):
parameters are the design variables by name with distributions of their bounds, metric
names the objectives', so a stored study reads in optuna-dashboard as the physical design.

Storages and resuming (rules, checked when the study is opened on the first ask):

* Building the strategy touches no storage: the study is opened (created when missing) on
  the first :meth:`~NSGA2.ask`, so a config check that builds the strategy leaves no study
  behind. :meth:`~NSGA2.check_storage` is the read-only check of the rule below (the
  optimize pipeline's config check calls it; a missing SQLite file is not created).
* Every trial the strategy creates carries the user attribute ``suspenv_run`` =
  ``[run id, batch, row]``; the run id is bound by :meth:`~NSGA2.bind_run` (the optimize
  pipeline binds the id stored in the run directory's archive, so a run directory keeps
  its id across resumes and a new or overwritten one gets a new id).
* A study that already holds trials of another run (any other or no run id) is refused
  with a :class:`~suspenv.core.errors.ValidationError` naming the storage, the study and
  the option, unless ``resume=True``: then the new trials are bred from the stored ones
  (e.g. several workers sharing one study, or continuing a finished study).
* Trials of the bound run itself are the run's own record: when suspenv resumes a run
  directory (the loop replays the strategy against the archive), each ask of a batch the
  study already holds returns that batch's stored trials (same designs as the archive),
  and the tell tells only the ones still running (a crash between ask and tell); later
  batches are asked from the sampler as usual. Their designs are bred from the same
  parents as an uninterrupted run's, but the sampler's random stream restarts at the
  resume, so they need not equal an uninterrupted run's designs (without a storage the
  replay reproduces an uninterrupted run exactly).
"""

from __future__ import annotations

import logging
import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import optuna
from optuna.distributions import BaseDistribution, FloatDistribution
from optuna.trial import FrozenTrial, TrialState

from suspenv.core.errors import ValidationError
from suspenv.core.options import flag, integer, number, optional, text
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import Strategy

CONSTRAINTS_KEY = "suspenv_constraints"
#: user attribute of every trial the strategy creates: [run id, batch, row]
RUN_KEY = "suspenv_run"
#: optuna >= 5 takes constraints per trial (``Trial.set_constraint``); older: constraints_func
PER_TRIAL_CONSTRAINTS = hasattr(optuna.trial.Trial, "set_constraint")


def constraints_of(trial: optuna.trial.FrozenTrial) -> list[float]:
    return list(trial.user_attrs.get(CONSTRAINTS_KEY, []))


def constraints_func(n_constraints: int) -> Any:
    """A sampler's ``constraints_func``: :func:`constraints_of` for optuna < 5 with
    constraints, else None (optuna 5 takes them per trial)."""
    return constraints_of if n_constraints and not PER_TRIAL_CONSTRAINTS else None


@contextmanager
def quiet() -> Iterator[None]:
    """optuna's experimental and deprecation warnings silenced (the adapters pass only
    supported arguments; the warnings would repeat on every trial)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        warnings.simplefilter("ignore", FutureWarning)
        yield


def tell_trials(
    study: optuna.Study,
    trials: list[tuple[int, optuna.trial.Trial]],
    values: np.ndarray,
    batch: EvaluationBatch,
    constrained: bool,
) -> None:
    """Tell ``study`` each ``(row, trial)`` of ``trials`` its row of ``batch``.

    A failed design (``ok`` False or a non-finite objective) is told as
    ``TrialState.FAIL``; otherwise the trial is told ``values[row]`` and, when
    ``constrained``, the row's scaled constraints (feasible when every value <= 0) through
    optuna's constraint mechanism: ``Trial.set_constraint`` from optuna 5 on, else the
    user attribute :data:`CONSTRAINTS_KEY` read by :func:`constraints_of`. An unknown
    constraint value (NaN) is told as a violation of 1e300 (optuna refuses NaN)."""
    failed = ~batch.rankable
    for i, trial in trials:
        if failed[i]:
            study.tell(trial, state=TrialState.FAIL)
            continue
        if constrained:
            g = np.nan_to_num(batch.scaled_constraints[i], nan=1e300, posinf=1e300, neginf=-1e300)
            if PER_TRIAL_CONSTRAINTS:
                for j, gj in enumerate(g):
                    trial.set_constraint(f"g{j}", float(gj))
            else:
                trial.set_user_attr(CONSTRAINTS_KEY, g.tolist())
        study.tell(trial, values[i].tolist())


class StudyDesign:
    """The design as an optuna study holds it.

    Unbound: ``u0 .. u{d-1}``, each ``FloatDistribution(0, 1)`` (the unit cube). Bound to a
    problem (:meth:`bind`, before the first ask): the problem's parameter names, each with
    ``FloatDistribution(low, high, log)`` of its design-space bounds, and the objectives'
    names as the study's metric names, so a live study (optuna-dashboard) reads as the
    physical design; asked values go back to the unit cube through the design space
    (:meth:`unit`).
    """

    def __init__(self, dim: int):
        self.space: Any = None
        self.metric_names: list[str] = []
        self.dists: dict[str, BaseDistribution] = {
            f"u{i}": FloatDistribution(0.0, 1.0) for i in range(dim)
        }

    def bind(self, problem: Any) -> None:
        """Name the study after ``problem`` (its ``space`` and ``objective_names``)."""
        space = problem.space
        if space.dim != len(self.dists):
            raise ValidationError(
                f"optuna study: the problem has {space.dim} design variables, but the "
                f"strategy was built for {len(self.dists)}"
            )
        self.space = space
        self.dists = {
            p.name: FloatDistribution(float(p.low), float(p.high), log=p.log)
            for p in space.parameters
        }
        self.metric_names = [str(n) for n in problem.objective_names]

    def unit(self, trials: list[Any]) -> np.ndarray:
        """(n, d) unit-cube designs of asked ``trials``, clipped to [0, 1]."""
        params = [t.params for t in trials]  # a deep copy per call on an asked Trial
        X = np.array([[p[n] for n in self.dists] for p in params], dtype=float)
        U = X if self.space is None else self.space.to_unit(X)
        return np.clip(U, 0.0, 1.0)

    def name_metrics(self, study: optuna.Study) -> None:
        """The objectives' names as the study's metric names (when it has one value per
        objective; optuna's CMA-ES is told a single weighted sum)."""
        if self.metric_names and len(study.directions) == len(self.metric_names):
            with quiet():  # "experimental" in optuna 3.2-5
                study.set_metric_names(self.metric_names)


def _of_run(trial: FrozenTrial, run_id: str | None) -> bool:
    """True when ``trial`` was created by the run ``run_id`` (never for None)."""
    tag = trial.user_attrs.get(RUN_KEY)
    return run_id is not None and isinstance(tag, list) and tag[:1] == [run_id]


class NSGA2(Strategy):
    """Non-dominated sorting genetic algorithm II (Deb et al. 2002), optuna backend.

    Options (checked at construction):
        population_size: designs per generation, an integer >= 2 (default 50).
        crossover_prob, mutation_prob, swapping_prob: probabilities in [0, 1] passed to
            optuna's sampler (mutation_prob None: optuna's default, 1 / d).
        storage: optuna storage URL (a non-empty string), or None for in-memory (default).
        study_name: study name in the storage (default "suspenv-nsga2-<seed>").
        resume: True to add to a study that already holds another run's trials (default
            False: such a study is refused; see the module docstring).

    A generation in which every design fails does not replace the population: optuna
    counts only completed trials towards a generation, so the next batch is bred from the
    same parents (failed trials take no part in selection).
    """

    name = "nsga2"
    description = "NSGA-II (optuna), one generation per batch, constraints supported"

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
        resume: bool = False,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        self.population_size = integer(owner, "population_size", population_size, lo=2)
        self.crossover_prob = number(owner, "crossover_prob", crossover_prob, lo=0.0, hi=1.0)
        self.mutation_prob = optional(number, owner, "mutation_prob", mutation_prob, lo=0.0, hi=1.0)
        self.swapping_prob = number(owner, "swapping_prob", swapping_prob, lo=0.0, hi=1.0)
        self.storage = optional(text, owner, "storage", storage)
        self.study_name = (
            f"suspenv-nsga2-{self.seed}"
            if study_name is None
            else text(owner, "study_name", study_name)
        )
        self.resume = bool(flag(owner, "resume", resume))
        optuna.logging.set_verbosity(logging.WARNING)
        with quiet():
            self._sampler = optuna.samplers.NSGAIISampler(
                population_size=self.population_size,
                crossover_prob=self.crossover_prob,
                mutation_prob=self.mutation_prob,
                swapping_prob=self.swapping_prob,
                seed=self.seed,
                constraints_func=constraints_func(self.n_constraints),
            )
        self._study: optuna.Study | None = None
        self._run_id: str | None = None
        self.design = StudyDesign(self.dim)
        self._trials: list[optuna.trial.Trial | FrozenTrial] = []
        #: stored trials of the bound run by batch (served again when a run is resumed)
        self._stored: dict[int, dict[int, FrozenTrial]] = {}
        self._batch = 0

    # ----------------------------------------------------------------- study
    def bind_run(self, run_id: str) -> None:
        """Tag this strategy's trials with ``run_id`` (before the first ask): the stored
        trials of the same run id are replayed, not refused (see the module docstring)."""
        if self._study is not None:
            raise RuntimeError(f"{self.name}: bind_run() must come before the first ask()")
        self._run_id = text(self.name, "run_id", run_id)

    def bind_problem(self, problem: Any) -> None:
        """Name the study's parameters and metrics after ``problem`` (before the first
        ask; :class:`StudyDesign`)."""
        if self._study is not None:
            raise RuntimeError(f"{self.name}: bind_problem() must come before the first ask()")
        self.design.bind(problem)

    @property
    def study(self) -> optuna.Study:
        """The optuna study, opened (created when missing) on first use."""
        if self._study is None:
            self._study = self._open_study()
        return self._study

    def _where(self) -> str:
        return f"optuna storage {self.storage!r}, study {self.study_name!r}"

    def _refuse_foreign(self, trials: list[FrozenTrial], run_id: str | None) -> None:
        """The resume rule: trials of another run than ``run_id`` need ``resume=True``."""
        foreign = [t for t in trials if not _of_run(t, run_id)]
        if foreign and not self.resume:
            raise ValidationError(
                f"{self.name}: the {self._where()} already holds {len(foreign)} trials of "
                "another run, and `resume = false` refuses to continue it; set "
                "`strategy.options.resume = true` to breed from them, or give another "
                "`strategy.options.study_name` or `storage`"
            )

    def _check_directions(self, study: optuna.Study) -> None:
        want = [optuna.study.StudyDirection.MINIMIZE] * self.n_objectives
        if list(study.directions) != want:
            got = [d.name.lower() for d in study.directions]
            raise ValidationError(
                f"{self.name}: the {self._where()} has directions {got}, but this run "
                f"minimises {self.n_objectives} objective(s); give another `study_name`"
            )

    def check_storage(self, run_id: str | None = None) -> None:
        """Read-only check of the resume rule before a run: creates no study, and no file
        for a SQLite storage that does not exist yet. ``run_id``: the id the run will bind
        (its own trials are allowed), None for a new run."""
        if self.storage is None:
            return
        if self.storage.startswith("sqlite:///"):
            path = self.storage.removeprefix("sqlite:///").partition("?")[0]
            if path not in ("", ":memory:") and not os.path.exists(path):
                return
        try:
            study = optuna.load_study(study_name=self.study_name, storage=self.storage)
        except KeyError:  # no such study
            return
        self._check_directions(study)
        self._refuse_foreign(study.get_trials(deepcopy=False), run_id)

    def _open_study(self) -> optuna.Study:
        study = self._load_or_create()
        self.design.name_metrics(study)
        return study

    def _load_or_create(self) -> optuna.Study:
        if self.storage is None:
            return optuna.create_study(
                sampler=self._sampler,
                study_name=self.study_name,
                directions=["minimize"] * self.n_objectives,
            )
        try:
            study = optuna.load_study(
                study_name=self.study_name, storage=self.storage, sampler=self._sampler
            )
        except KeyError:  # not there yet; another worker may create it meanwhile
            study = optuna.create_study(
                storage=self.storage,
                sampler=self._sampler,
                study_name=self.study_name,
                directions=["minimize"] * self.n_objectives,
                load_if_exists=True,
            )
        self._check_directions(study)
        trials = study.get_trials(deepcopy=False)
        self._refuse_foreign(trials, self._run_id)
        for t in trials:
            if _of_run(t, self._run_id):
                _, batch, row = t.user_attrs[RUN_KEY]
                self._stored.setdefault(int(batch), {})[int(row)] = t
        return study

    def _new_trial(self, batch: int, row: int) -> optuna.trial.Trial:
        trial = self.study.ask(self.design.dists)
        trial.set_user_attr(RUN_KEY, [self._run_id, batch, row])
        return trial

    def _ask(self) -> np.ndarray:
        if self._study is None:  # open it (and read the stored trials) first
            self._study = self._open_study()
        b, self._batch = self._batch, self._batch + 1
        stored = self._stored.pop(b, {})
        self._trials = [
            stored[r] if r in stored else self._new_trial(b, r) for r in range(self.population_size)
        ]
        return self.design.unit(self._trials)

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        pending: list[tuple[int, optuna.trial.Trial]] = []
        for i, asked in enumerate(self._trials):
            if isinstance(asked, FrozenTrial):  # a stored trial, served again on a resume
                if asked.state.is_finished():
                    continue  # told before the run stopped
                # asked before the run stopped, never told: tell it now
                pending.append((i, optuna.trial.Trial(self.study, asked._trial_id)))
            else:
                pending.append((i, asked))
        tell_trials(self.study, pending, batch.objectives, batch, bool(self.n_constraints))
        self._trials = []
