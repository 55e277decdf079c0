"""Designs of the unit cube [0, 1]^d evaluated in batches (the profile scans'
evaluations; the pipeline's Latin hypercube is the ``lhs`` strategy, run and archived
by :func:`suspenv.runs.loop.optimize`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch


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
