"""Contract tests run on every registered problem (new problems are covered for free)."""

import numpy as np
import pytest

from suspenv import list_problems, make_problem
from suspenv.core import EvaluationBatch, Problem
from suspenv.core.errors import ValidationError


@pytest.fixture(scope="module", params=list_problems())
def problem(request) -> Problem:
    return make_problem(request.param)


def test_defaults_build_and_describe(problem):
    assert isinstance(problem, Problem)
    assert problem.space.dim >= 1 and problem.n_objectives >= 1
    assert len(set(problem.objective_names)) == problem.n_objectives
    assert problem.description, "every problem describes itself in one line"
    if problem.objective_units:
        assert len(problem.objective_units) == problem.n_objectives


def test_reference_design_inside_bounds(problem):
    x = problem.reference_design()
    assert problem.space.outside_bounds(x) == []


def test_batch_shapes_and_determinism(problem):
    rng = np.random.default_rng(0)
    U = np.vstack(
        [
            problem.space.to_unit(problem.reference_design()[None, :]),
            rng.uniform(0.2, 0.8, (2, problem.space.dim)),
        ]
    )
    a = problem.evaluate_unit(U)
    b = problem.evaluate_unit(U)
    assert isinstance(a, EvaluationBatch) and len(a) == 3
    assert a.objectives.shape == (3, problem.n_objectives)
    assert a.constraints.shape == (3, problem.n_constraints)
    assert a.ok[0], f"reference design failed: {a.messages[0]}"
    assert np.isfinite(a.objectives[a.ok]).all()
    np.testing.assert_array_equal(a.objectives, b.objectives)  # same input, same numbers
    assert all(m for m, ok in zip(a.messages, a.ok, strict=True) if not ok)


def test_batch_equals_rows_one_at_a_time(problem):
    U = np.random.default_rng(1).uniform(0.3, 0.7, (3, problem.space.dim))
    batch = problem.evaluate_unit(U)
    for i in range(3):
        one = problem.evaluate_unit(U[i : i + 1])
        np.testing.assert_allclose(one.objectives[0], batch.objectives[i], rtol=1e-9, atol=1e-12)


def test_nan_design_rejected(problem):
    X = problem.reference_design()[None, :].copy()
    X[0, 0] = np.nan
    with pytest.raises(ValidationError, match="must be finite"):
        problem.evaluate(X)


def test_numbers_do_not_depend_on_the_batch_split(problem):
    # same designs evaluated as one batch and as two halves agree to rounding (BLAS may
    # block other batch sizes differently), so runs with other worker counts or chunk
    # sizes agree to ~1e-15; float32 physics would drift at ~1e-7 and fail this
    U = np.random.default_rng(2).uniform(0.25, 0.75, (6, problem.space.dim))
    whole = problem.evaluate_unit(U).objectives
    halves = np.vstack(
        [problem.evaluate_unit(U[:3]).objectives, problem.evaluate_unit(U[3:]).objectives]
    )
    np.testing.assert_allclose(whole, halves, rtol=1e-12, atol=1e-12)
