"""Design of experiments: a Latin hypercube over a design space, evaluated in batches.

Designs are drawn in the unit cube [0, 1]^d (one stratum per sample in every
dimension) and mapped to physical values by the problem's :class:`DesignSpace`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from suspenv.core.errors import ValidationError
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch


def latin_hypercube(n_samples: int, dim: int, seed: int | None = 0) -> np.ndarray:
    """``n_samples`` Latin hypercube points in [0, 1]^dim, shape (n_samples, dim).

    Each column holds exactly one point in each of the ``n_samples`` equal strata.
    """
    if int(n_samples) < 2:
        raise ValidationError(f"`n_samples >= 2` must hold, but got n_samples={n_samples}")
    if int(dim) < 1:
        raise ValidationError(f"`dim >= 1` must hold, but got dim={dim}")
    sampler = qmc.LatinHypercube(d=int(dim), rng=np.random.default_rng(seed))
    return sampler.random(int(n_samples))


@dataclass
class DoEResult:
    """A design of experiments and its evaluations.

    Attributes:
        unit: (n, d) designs in the unit cube.
        x: (n, d) physical designs.
        batch: the evaluations of all n designs (row-aligned with ``x``).
    """

    unit: np.ndarray
    x: np.ndarray
    batch: EvaluationBatch

    @property
    def valid(self) -> np.ndarray:
        """(n,) rows that evaluated and are feasible."""
        return self.batch.feasible & np.isfinite(self.batch.objectives).all(axis=1)


def evaluate_in_batches(
    problem: Problem,
    unit: np.ndarray,
    batch_size: int = 100,
    progress: bool = False,
    on_batch: Callable[[int, EvaluationBatch], None] | None = None,
    desc: str = "design of experiments",
) -> EvaluationBatch:
    """Evaluate unit-cube designs in batches of ``batch_size`` (vectorised per batch).

    ``on_batch(start_row, batch)`` is called after each batch (e.g. to save progress).
    """
    unit = problem.space.check_batch(unit, what="unit design batch")
    if int(batch_size) < 1:
        raise ValidationError(f"`batch_size >= 1` must hold, but got batch_size={batch_size}")
    starts = range(0, unit.shape[0], int(batch_size))
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=unit.shape[0], desc=desc, unit="design")
    parts = []
    try:
        for start in starts:
            part = problem.evaluate_unit(unit[start : start + int(batch_size)])
            parts.append(part)
            if on_batch is not None:
                on_batch(start, part)
            if bar is not None:
                bar.update(len(part))
    finally:
        if bar is not None:
            bar.close()
    return EvaluationBatch.concatenate(parts)


def run_doe(
    problem: Problem,
    n_samples: int = 500,
    seed: int | None = 0,
    batch_size: int = 100,
    progress: bool = False,
    on_batch: Callable[[int, EvaluationBatch], None] | None = None,
) -> DoEResult:
    """Latin hypercube of ``n_samples`` designs over ``problem.space``, evaluated in batches."""
    unit = latin_hypercube(n_samples, problem.space.dim, seed)
    batch = evaluate_in_batches(problem, unit, batch_size, progress, on_batch)
    return DoEResult(unit=unit, x=problem.space.to_physical(unit), batch=batch)
