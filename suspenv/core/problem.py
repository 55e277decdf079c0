"""The problem seam: a design space plus a batch evaluation.

A problem is *what we want*: it owns a :class:`DesignSpace`, names its objectives
(minimised) and constraints (feasible when <= 0), and evaluates a batch of physical
designs ``X`` of shape (n, d). Subclasses implement :meth:`_evaluate`, vectorised
over the batch where the physics allows.

Failures are values, not crashes: any :class:`Exception` raised by ``_evaluate`` is
isolated to the rows that caused it (the batch is re-run row by row) and those rows
come back with ``ok=False`` and the exception's message. A row reported ok whose
objectives or constraints are not finite is a failed row too. A :class:`MemoryError` is a
fault of the machine, not of the design: it propagates (the run loop retries it).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from suspenv.core.result import EvaluationBatch, check_scales
from suspenv.core.space import DesignSpace


class Problem(ABC):
    """Base class of every problem.

    Class attributes to set in subclasses:
        name: registry name, e.g. ``"KCIdentification"``. A view of another problem
            (:mod:`suspenv.problems.views`) overrides it per instance, so it is not a ClassVar.
        description: one line for ``suspenv list``.

    Instance attributes set by subclasses' ``__init__``:
        space: the :class:`DesignSpace`.
        objective_names: names of the m objectives (minimised).
        constraint_names: names of the k constraints (feasible when <= 0).
        constraint_scales: k scales, each > 0 in its constraint's unit, that make the
            total violation dimensionless (:mod:`suspenv.core.result`): e.g. the
            magnitude of the limit the constraint compares with. Empty (default): every
            scale is 1, for constraints that are already dimensionless.
        objective_units: optional units, same length as ``objective_names``.

    Optional method:
        render_rgb: ``render_rgb(x_physical) -> uint8 (H, W, 3)``, a picture of one design
            (the gym environment's ``rgb_array`` rendering); None when the problem cannot draw.
    """

    name: str = "Problem"
    description: ClassVar[str] = ""

    space: DesignSpace
    objective_names: tuple[str, ...]
    constraint_names: tuple[str, ...] = ()
    constraint_scales: tuple[float, ...] = ()
    objective_units: tuple[str, ...] = ()
    render_rgb: Callable[[np.ndarray], np.ndarray] | None = None
    #: objectives that may be NaN in a successful row: columns a view adds for information
    #: (e.g. signed responses a base problem does not provide); everywhere else a
    #: non-finite objective fails the row
    informational_objectives: tuple[str, ...] = ()
    #: seconds one design may take before the run loop calls it a fault of the machinery
    #: (``run.timeout_s`` overrides it); generous: a bound on hangs, not a deadline
    timeout_s: float = 60.0

    # ------------------------------------------------------------ subclass API
    @abstractmethod
    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        """Evaluate physical designs X (n, d), already validated. May raise."""

    # ------------------------------------------------------------- public API
    @property
    def n_objectives(self) -> int:
        return len(self.objective_names)

    @property
    def n_constraints(self) -> int:
        return len(self.constraint_names)

    def evaluate(self, X: np.ndarray) -> EvaluationBatch:
        """Evaluate a batch of physical designs (n, d) -> :class:`EvaluationBatch`.

        Raises :class:`~suspenv.core.errors.ValidationError` for a malformed batch
        (wrong shape, NaN/inf) or malformed :attr:`constraint_scales`, before any work.
        Physics failures become failed rows. The batch carries the constraint scales.
        """
        X = self.space.check_batch(X)
        scales = self._checked_constraint_scales()
        try:
            batch = self._evaluate(X)
        except MemoryError:
            raise
        except Exception as exc:  # noqa: BLE001 - a failed evaluation is a value
            if X.shape[0] == 1:
                msg = f"{type(exc).__name__}: {exc}"
                failed = EvaluationBatch.failed(1, self.n_objectives, self.n_constraints, msg)
                return self.with_scales(failed)
            # isolate the failing rows
            return EvaluationBatch.concatenate([self.evaluate(x[None, :]) for x in X])
        self._check_shapes(batch, X.shape[0])
        batch = self._non_finite_failed(batch)
        batch.constraint_scales = scales
        return batch

    def with_scales(self, batch: EvaluationBatch) -> EvaluationBatch:
        """``batch`` carrying this problem's :attr:`constraint_scales` (None when none
        are declared: every scale 1), e.g. for rows read back from an archive."""
        batch.constraint_scales = self._checked_constraint_scales()
        return batch

    def _checked_constraint_scales(self) -> np.ndarray | None:
        """:attr:`constraint_scales` checked (:func:`check_scales`), or None when empty;
        checked again only when they or the number of constraints are replaced."""
        scales, k = self.constraint_scales, self.n_constraints
        if not scales:
            return None
        hit = self.__dict__.get("_scales_checked")
        if hit is None or hit[0] is not scales or hit[1] != k:
            checked = check_scales(scales, k)
            checked.flags.writeable = False  # one array shared by the batches
            hit = self._scales_checked = (scales, k, checked)
        return hit[2]

    def evaluate_unit(self, U: np.ndarray) -> EvaluationBatch:
        """Evaluate unit-cube designs (n, d)."""
        return self.evaluate(self.space.to_physical(U))

    def reference_design(self) -> np.ndarray:
        """The physical reference design (1-D)."""
        return self.space.reference()

    def config(self) -> dict[str, Any]:
        """Options that rebuild this problem (stored in run directories)."""
        return {}

    def quality(self, F: np.ndarray) -> np.ndarray | None:
        """One number per row to compare runs and strategies (lower is better), or None.

        Default: the objective itself for one objective; None for several, whose units
        differ: they have no scalar best (runs are compared by their fronts, see
        :mod:`suspenv.runs.quality`). A problem whose objectives share a scale may
        override this.
        """
        F = np.atleast_2d(F)
        return F[:, 0] if F.shape[1] == 1 else None

    quality_name: ClassVar[str] = "objective"

    @property
    def objective_scales(self) -> np.ndarray | None:
        """(m,) scale of each objective in its unit (finite, > 0) that makes
        ``f_j / s_j`` comparable across objectives, or None (default) when the problem
        declares none. Used by the envs' normalised reward (:mod:`suspenv.envs.scales`),
        which falls back to its own rule without them."""
        return None

    def write_report(self, run_dir: Path, archive: Any) -> list[Path]:
        """Problem-specific report files for a finished run (optional). Returns paths."""
        return []

    # --------------------------------------------------------------- helpers
    def _non_finite_failed(self, batch: EvaluationBatch) -> EvaluationBatch:
        """``batch`` with every ok row whose objectives (but the
        :attr:`informational_objectives`) or constraints are not all finite turned into a
        failed row (NaN values, a message naming what was not finite)."""
        if np.isfinite(batch.objectives).all() and np.isfinite(batch.constraints).all():
            return batch  # nothing to check (the common case)
        objective_names, constraint_names = self.objective_names, self.constraint_names
        informational = self.informational_objectives
        checked = np.array([name not in informational for name in objective_names], dtype=bool)
        bad = batch.ok & ~(
            np.isfinite(batch.objectives[:, checked]).all(axis=1)
            & np.isfinite(batch.constraints).all(axis=1)
        )
        if not bad.any():
            return batch
        messages = list(batch.messages)
        for i in np.flatnonzero(bad):
            f, g = batch.objectives[i], batch.constraints[i]
            parts = [
                f"{objective_names[j]}={f[j]}"
                for j in np.flatnonzero(checked & ~np.isfinite(f)).tolist()
            ]
            parts += [
                f"{constraint_names[j]}={g[j]}" for j in np.flatnonzero(~np.isfinite(g)).tolist()
            ]
            messages[i] = "non-finite result: " + ", ".join(parts)
        ok = batch.ok & ~bad
        return EvaluationBatch(
            np.where(bad[:, None], np.nan, batch.objectives),
            np.where(bad[:, None], np.nan, batch.constraints),
            ok,
            messages,
            batch.extras,
        )

    def _check_shapes(self, batch: EvaluationBatch, n: int) -> None:
        want = (n, self.n_objectives), (n, self.n_constraints)
        got = batch.objectives.shape, batch.constraints.shape
        if got != want:
            raise RuntimeError(
                f"{type(self).__name__}._evaluate must return objectives {want[0]} and "
                f"constraints {want[1]}, but returned {got[0]} and {got[1]}"
            )

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(d={self.space.dim}, m={self.n_objectives}, "
            f"k={self.n_constraints})"
        )
