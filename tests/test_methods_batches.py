"""Unit-cube designs evaluated in batches (the profile scans' evaluations)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc
from synthetic_problem import SyntheticIdentification

from suspenv.core.errors import ValidationError
from suspenv.methods.tey2014.identification import evaluate_in_batches
from suspenv.problems.toy import Sphere


def latin_hypercube(n: int, d: int, seed: int) -> np.ndarray:
    return qmc.LatinHypercube(d=d, rng=np.random.default_rng(seed)).random(n)


def test_batched_evaluation_equals_one_batch():
    # the batch split must not change any value: compare with one whole-batch evaluation
    problem = Sphere(dim=4)
    U = latin_hypercube(23, 4, seed=0)
    batch = evaluate_in_batches(problem, U, batch_size=5)
    whole = problem.evaluate_unit(U)
    np.testing.assert_array_equal(batch.objectives, whole.objectives)


def test_batches_keep_failed_and_infeasible_rows_aligned():
    problem = SyntheticIdentification()
    unit = latin_hypercube(200, 8, seed=0)
    batch = evaluate_in_batches(problem, unit, batch_size=64)
    x = problem.space.to_physical(unit)
    assert len(batch) == 200
    # planted failure region spare_2 > 0.98 and infeasible region d1 + d2 > 1.8
    failed = x[:, 7] > 0.98
    infeasible = x[:, 4] + x[:, 5] > 1.8
    assert np.array_equal(~batch.ok, failed)
    valid = batch.feasible & np.isfinite(batch.objectives).all(axis=1)
    assert np.array_equal(valid, ~failed & ~infeasible)


def test_bad_sizes_are_rejected():
    with pytest.raises(ValidationError, match="batch_size >= 1"):
        evaluate_in_batches(Sphere(2), np.zeros((3, 2)), batch_size=0)
