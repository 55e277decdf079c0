"""Nevergrad's optimisers behind the ask/tell seam (extra ``nevergrad``).

Any name of ``nevergrad.optimizers.registry`` (about 540: ``TwoPointsDE``, ``CMA``,
``PSO``, ``OnePlusOne``, the ``NGOpt`` wizard, ...) runs on the unit cube:

- The design is one ``nevergrad.p.Array`` of ``d`` floats with bounds [0, 1] (started at
  the centre); every asked design is inside the box.
- ``batch_size`` is nevergrad's ``num_workers``: each :meth:`ask` asks that many
  candidates before any of them is told. Optimisers that cannot run in parallel (e.g.
  ``Cobyla``, ``Powell``) refuse ``batch_size > 1`` at construction.
- Seeded: the parametrization's ``random_state`` is ``numpy.random.RandomState(seed)``,
  set before the optimiser is built; a strategy rebuilt with the same seed and options
  and told the same results asks the same designs (tested for the default optimiser and
  a few others; an optimiser of nevergrad's registry that draws from numpy's global
  generator would not be reproducible, and is nevergrad's to fix).
- Several objectives: each design is told its vector of objectives. nevergrad's
  differential evolution (``TwoPointsDE``, ``DE``, ...) selects by Pareto dominance; the
  other optimisers minimise nevergrad's hypervolume scalarisation (the hypervolume a
  design adds below ``reference_point`` when given, else below nevergrad's automatic
  bound from its first 15 tells), which is erratic on ZDT1 in our tests (CMA, PSO,
  OnePlusOne): use a DE variant for several objectives. ``ng_optimizer.pareto_front()``
  holds the front.
- Failed and infeasible designs are told large finite losses
  (:func:`suspenv.strategies.extras.told_losses`): a failed design ``1e12`` in every
  objective, an infeasible one a value in [1e9, 2e9) growing with its total violation.
  nevergrad's own ``constraint_violation`` argument is not used: without a budget its
  penalty is proportional to the loss, so it vanishes for a loss of zero or below. In a
  batch, feasible designs are told first, so that nevergrad's automatic multi-objective
  bound is taken from them; give ``reference_point`` when the first designs may all fail.

Note: nevergrad 1.0.12's ``MetaModel`` (which ``NGOpt`` and the other wizards pick for
some dimensions and budgets) fails under numpy >= 2.4 ("only 0-dimensional arrays can be
converted to Python scalars", nevergrad issue #1612); the adapter names the cause when it
happens. The default optimiser, ``TwoPointsDE``, does not use it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import did_you_mean, integer, numbers, optional, text
from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import Strategy
from suspenv.strategies.extras import require, told_losses

#: the wizards of nevergrad's registry that choose their algorithm from the budget
_NEEDS_BUDGET = "NGOptBase"


class Nevergrad(Strategy):
    """A nevergrad optimiser on the unit cube.

    Options (checked at construction):
        optimizer: a name of ``nevergrad.optimizers.registry`` (default "TwoPointsDE");
            a typo is refused with the nearest names.
        batch_size: candidates per ask (nevergrad's ``num_workers``), an integer >= 1
            (default 1).
        budget: the evaluations nevergrad plans for, an integer >= 1, or None (default).
            ``NGOpt`` and the other wizards choose their algorithm from it and need it;
            sampling optimisers (e.g. ``LHSSearch``) stop at it. When given, the last
            batch is cut to it and :meth:`stop` says so once that many designs have been
            told.
        reference_point: for several objectives, the upper bound of each objective for
            nevergrad's hypervolume scalarisation (a list of finite numbers, one per
            objective), or None (default: nevergrad's automatic bound from its first 15
            tells); DE variants select by Pareto dominance and do not use it.
    """

    name = "nevergrad"
    description = "any nevergrad optimiser (default TwoPointsDE); needs suspenv[nevergrad]"

    def __init__(
        self,
        dim: int,
        n_objectives: int = 1,
        n_constraints: int = 0,
        seed: int = 0,
        optimizer: str = "TwoPointsDE",
        batch_size: int = 1,
        budget: int | None = None,
        reference_point: list[float] | None = None,
    ):
        super().__init__(dim, n_objectives, n_constraints, seed)
        owner = self.name
        self.batch_size = integer(owner, "batch_size", batch_size, lo=1)
        self.budget = optional(integer, owner, "budget", budget, lo=1)
        if reference_point is not None and self.n_objectives == 1:
            raise ValidationError(
                f"{owner}: `reference_point` applies only with several objectives, but the "
                f"problem has one (reference_point={reference_point!r})"
            )
        self.reference_point = optional(
            numbers, owner, "reference_point", reference_point, self.n_objectives
        )
        text(owner, "optimizer", optimizer)
        ng = require(owner, "nevergrad", "nevergrad")
        registry = ng.optimizers.registry
        if optimizer not in registry:
            raise ValidationError(
                f"{owner}: `optimizer` must be a name of nevergrad.optimizers.registry "
                f"({len(registry)} names), but got optimizer={optimizer!r}"
                + did_you_mean(optimizer, registry)
            )
        self.optimizer = optimizer
        factory = registry[optimizer]
        wizard = getattr(ng.optimizers, _NEEDS_BUDGET, None)
        if (
            self.budget is None
            and isinstance(factory, type)
            and wizard is not None
            and issubclass(factory, wizard)
        ):
            raise ValidationError(
                f"{owner}: optimizer={optimizer!r} chooses its algorithm from the budget, so "
                f"`budget` (the run's evaluation budget, an integer >= 1) must be given, but "
                f"got budget=None"
            )
        if self.batch_size > 1 and getattr(factory, "no_parallelization", False):
            raise ValidationError(
                f"{owner}: optimizer={optimizer!r} runs one design at a time (nevergrad's "
                f"no_parallelization), so `batch_size == 1` must hold, but got "
                f"batch_size={self.batch_size}"
            )
        # nevergrad seeds a parameter's random state, when first needed, from numpy's global
        # generator, and building a bounded Array needs one; that draw is undone (the state
        # is replaced by the seeded one below), so the caller's global stream is untouched
        state = np.random.get_state()
        try:
            parametrization = ng.p.Array(init=np.full(self.dim, 0.5), lower=0.0, upper=1.0)
        finally:
            np.random.set_state(state)
        parametrization.random_state = np.random.RandomState(self.seed)
        try:
            self.ng_optimizer = factory(
                parametrization=parametrization,
                budget=self.budget,
                num_workers=self.batch_size,
            )
        except (ValueError, TypeError, AssertionError) as exc:
            raise ValidationError(
                f"{owner}: nevergrad refuses optimizer={optimizer!r} with "
                f"batch_size={self.batch_size} and budget={self.budget}: {exc}"
            ) from exc
        self._ng = ng
        self._candidates: list[Any] = []
        self._reference_told = False

    def _call(self, what: str, fn: Any, *args: Any) -> Any:
        """Call nevergrad; its errors are re-raised naming the optimiser and the step."""
        try:
            return fn(*args)
        except Exception as exc:
            hint = ""
            if isinstance(exc, TypeError) and "0-dimensional" in str(exc):
                hint = (
                    " (nevergrad's MetaModel fails under numpy >= 2.4, nevergrad issue "
                    "#1612; choose an optimizer without it, e.g. 'TwoPointsDE' or 'CMA')"
                )
            raise RuntimeError(
                f"{self.name}: nevergrad's {self.optimizer!r} failed in {what} after "
                f"{self.n_told} told designs: {type(exc).__name__}: {exc}{hint}"
            ) from exc

    def _ask(self) -> np.ndarray:
        opt = self.ng_optimizer
        n = self.batch_size
        if self.budget is not None:  # the last batch stops at the budget
            n = max(1, min(n, self.budget - self.n_told))
        self._candidates = [self._call("ask", opt.ask) for _ in range(n)]
        U = np.array([np.asarray(c.value, dtype=float) for c in self._candidates])
        return np.clip(U, 0.0, 1.0)

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        opt = self.ng_optimizer
        losses = told_losses(batch)
        if self.reference_point is not None and not self._reference_told:
            reference = self._ng.p.MultiobjectiveReference()
            self._call("tell", opt.tell, reference, np.asarray(self.reference_point, float))
            self._reference_told = True
        # feasible designs first: nevergrad's automatic multi-objective bound comes from the
        # first tells (otherwise the order of the tells of a batch matters little)
        order = np.argsort(~batch.feasible, kind="stable")
        for i in order:
            loss = float(losses[i, 0]) if self.n_objectives == 1 else losses[i].copy()
            self._call("tell", opt.tell, self._candidates[i], loss)
        self._candidates = []

    def stop(self) -> str | None:
        if self.budget is not None and self.n_told >= self.budget and self._pending is None:
            return f"nevergrad: budget={self.budget} designs told"
        return None
