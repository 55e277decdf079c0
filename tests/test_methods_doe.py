"""Latin hypercube design of experiments, evaluated in batches."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.methods.tey2014.doe import evaluate_in_batches, latin_hypercube, run_doe
from suspenv.problems.synthetic import SyntheticIdentification
from suspenv.problems.toy import Sphere


def test_latin_hypercube_has_one_point_per_stratum():
    # definition of a Latin hypercube: each of n equal strata of each axis holds one point
    n, d = 50, 7
    U = latin_hypercube(n, d, seed=3)
    assert U.shape == (n, d)
    for j in range(d):
        strata = np.floor(U[:, j] * n).astype(int)
        assert sorted(strata) == list(range(n))


def test_latin_hypercube_is_seeded():
    assert np.array_equal(latin_hypercube(10, 3, seed=1), latin_hypercube(10, 3, seed=1))
    assert not np.array_equal(latin_hypercube(10, 3, seed=1), latin_hypercube(10, 3, seed=2))


def test_batched_evaluation_equals_one_batch():
    # the batch split must not change any value: compare with one whole-batch evaluation
    problem = Sphere(dim=4)
    U = latin_hypercube(23, 4, seed=0)
    seen = []
    batch = evaluate_in_batches(problem, U, batch_size=5, on_batch=lambda s, b: seen.append(s))
    assert seen == [0, 5, 10, 15, 20]
    whole = problem.evaluate_unit(U)
    np.testing.assert_array_equal(batch.objectives, whole.objectives)


def test_run_doe_keeps_failed_and_infeasible_rows_aligned():
    problem = SyntheticIdentification()
    doe = run_doe(problem, n_samples=200, seed=0, batch_size=64)
    assert doe.x.shape == (200, 8) and len(doe.batch) == 200
    np.testing.assert_allclose(doe.x, problem.space.to_physical(doe.unit))
    # planted failure region spare_2 > 0.98 and infeasible region d1 + d2 > 1.8
    failed = doe.x[:, 7] > 0.98
    infeasible = doe.x[:, 4] + doe.x[:, 5] > 1.8
    assert np.array_equal(~doe.batch.ok, failed)
    assert np.array_equal(doe.valid, ~failed & ~infeasible)


def test_bad_sizes_are_rejected():
    with pytest.raises(ValidationError, match="n_samples >= 2"):
        latin_hypercube(1, 3)
    with pytest.raises(ValidationError, match="batch_size >= 1"):
        evaluate_in_batches(Sphere(2), np.zeros((3, 2)), batch_size=0)
