"""The strategy seam: ``ask() -> U (n, d)`` in the unit cube, ``tell(U, batch)``, ``stop()``.

Strategies never see units: the problem's :class:`~suspenv.core.DesignSpace` maps the
unit cube to physical values in one place. A strategy must be told every design it asked,
once, in the order asked, before it is asked again.

The loop, as every strategy is driven::

    strategy = CMAES(dim=problem.space.dim, n_objectives=problem.n_objectives, seed=1)
    while strategy.stop() is None:
        U = strategy.ask()                       # (n, d) in [0, 1]
        batch = problem.evaluate_unit(U)         # EvaluationBatch
        strategy.tell(U, batch)

:func:`suspenv.runs.loop.optimize` adds the budget, the archive, executors and progress.
A user-written strategy plugs in by subclassing :class:`Strategy` (or just providing the
three methods) and calling :func:`suspenv.registry.register_strategy`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import choice, integer, numbers, option_names, optional
from suspenv.core.result import EvaluationBatch
from suspenv.core.scalarize import SCALARIZERS, get_scalarizer, penalized_fitness


def popsize_option(owner: str, popsize: Any, dim: int) -> int:
    """``popsize``, an integer >= 2, or for None pycma's default 4 + floor(3 ln d)."""
    if popsize is None:
        return 4 + int(3 * math.log(dim))
    return integer(owner, "popsize", popsize, lo=2)


class Strategy(ABC):
    """Base class: stores the problem's shape and the seed; checks ask/tell pairing."""

    name: ClassVar[str] = "strategy"
    description: ClassVar[str] = ""
    #: the options :meth:`options` records, in order: each an attribute of that name;
    #: empty: the constructor's keyword options after those of this base class (and
    #: :attr:`base_options`, which a base class records itself)
    option_names: ClassVar[tuple[str, ...]] = ()
    base_options: ClassVar[tuple[str, ...]] = ()

    def __init__(self, dim: int, n_objectives: int = 1, n_constraints: int = 0, seed: int = 0):
        """Rules: ``dim >= 1``, ``n_objectives >= 1``, ``n_constraints >= 0`` and
        ``seed >= 0``, all integers (:func:`suspenv.core.options.integer`)."""
        self.dim = integer(self.name, "dim", dim, lo=1)
        self.n_objectives = integer(self.name, "n_objectives", n_objectives, lo=1)
        self.n_constraints = integer(self.name, "n_constraints", n_constraints, lo=0)
        self.seed = integer(self.name, "seed", seed, lo=0)
        self._pending: np.ndarray | None = None
        self.n_told = 0

    # ------------------------------------------------------------- the seam
    def ask(self) -> np.ndarray:
        """Designs to evaluate next, (n, d) in the unit cube."""
        if self._pending is not None:
            raise RuntimeError(
                f"{self.name}: ask() called again before tell() for the previous "
                f"{len(self._pending)} designs"
            )
        U = np.atleast_2d(np.asarray(self._ask(), dtype=float))
        if U.ndim != 2 or U.shape[1] != self.dim:
            raise RuntimeError(f"{self.name}: _ask returned shape {U.shape}, want (n, {self.dim})")
        self._pending = U
        return U.copy()

    def tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        """Report the results of the designs last asked (all of them, same order)."""
        if self._pending is None:
            raise RuntimeError(f"{self.name}: tell() called without a preceding ask()")
        U = np.asarray(U, dtype=float)
        if U.shape != self._pending.shape or len(batch) != U.shape[0]:
            raise ValidationError(
                f"{self.name}: tell() needs the whole asked population, but got "
                f"{U.shape[0]} designs and {len(batch)} results for {len(self._pending)} asked"
            )
        if not np.array_equal(U, self._pending):
            raise ValidationError(f"{self.name}: tell() got designs that differ from those asked")
        self._pending = None
        self._tell(U, batch)
        self.n_told += len(batch)

    def stop(self) -> str | None:
        """A reason to stop (string), or None to go on."""
        return None

    def options(self) -> dict[str, Any]:
        """Resolved options (recorded with the run): the attributes :attr:`option_names`."""
        names = self.option_names or option_names(
            type(self), (*(option_names(Strategy) or ()), *self.base_options)
        )
        return {k: getattr(self, k) for k in names or ()}

    # ------------------------------------------------------------ subclasses
    @abstractmethod
    def _ask(self) -> np.ndarray: ...

    @abstractmethod
    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None: ...


class ScalarStrategy(Strategy):
    """A single-objective strategy; several objectives are scalarised per batch.

    Options:
        scalarizer: "weighted_sum" (default) or "rank_sum" (Tey et al. 2014), used when
            the problem has more than one objective.
        weights: weights for "weighted_sum": one finite number per objective (default all
            1); refused with "rank_sum", which takes none.
    """

    base_options = ("scalarizer", "weights")

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        scalarizer: str = "weighted_sum",
        weights: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        self.scalarizer_name = choice(self.name, "scalarizer", scalarizer, sorted(SCALARIZERS))
        self._scalarizer = get_scalarizer(self.scalarizer_name)
        if weights is not None and self.scalarizer_name != "weighted_sum":
            raise ValidationError(
                f"{self.name}: `weights` apply only with scalarizer='weighted_sum', but got "
                f"scalarizer={self.scalarizer_name!r} and weights={weights!r}"
            )
        self.weights = optional(numbers, self.name, "weights", weights, self.n_objectives)

    def fitness(self, batch: EvaluationBatch) -> np.ndarray:
        """Finite fitness per row: scalarised objectives, infeasible and failed rows last."""
        if batch.n_objectives == 1:
            f = np.where(batch.ok, batch.objectives[:, 0], np.nan)
        elif self.scalarizer_name == "weighted_sum":
            f = self._scalarizer(batch.objectives, self.weights, valid=batch.ok)
        else:
            # rank over the feasible rows only, as Tey et al. remove infeasible designs
            f = self._scalarizer(batch.objectives, valid=batch.feasible)
            f = np.where(batch.ok & ~batch.feasible, 0.0, f)
        return penalized_fitness(f, batch.ok, batch.violation)

    def options(self) -> dict[str, Any]:
        return {"scalarizer": self.scalarizer_name, "weights": self.weights, **super().options()}
