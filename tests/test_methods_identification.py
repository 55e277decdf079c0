"""Re-ranking, Table 1/2 equivalents and identifiability on a problem with a known truth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc
from synthetic_problem import SyntheticIdentification

from suspenv.core import DesignSpace, Parameter
from suspenv.methods.tey2014.identification import (
    FixedRankSum,
    evaluate_in_batches,
    identify,
    improvement_table,
    local_sensitivity,
    objective_scale,
    profile_scan,
    readable_basis,
    recovery_table,
    rerank_archive,
)


def test_rerank_uses_only_valid_rows():
    F = np.array([[1.0, 10.0], [0.0, 0.0], [2.0, 20.0], [np.nan, 0.0]])
    valid = np.array([True, False, True, True])
    fit = rerank_archive(F, valid)
    # row 1 is infeasible (excluded from min/max), row 3 failed: rank over rows 0 and 2
    assert fit[0] == 0.0 and fit[2] == 20.0
    assert np.isnan(fit[1]) and np.isnan(fit[3])


def test_identify_mean_and_std_of_best_designs():
    space = DesignSpace([Parameter("p", 0.0, 10.0), Parameter("q", 0.0, 10.0)])
    X = np.array([[1.0, 1.0], [2.0, 3.0], [9.0, 9.0], [4.0, 5.0]])
    F = np.abs(X - 1.0)  # mismatch to the truth (1, 1): rows ordered 0, 1, 3, 2
    res = identify(X, F, np.ones(4, bool), space, top=2)
    assert list(res.top_rows) == [0, 1]
    np.testing.assert_allclose(res.mean, [1.5, 2.0])
    np.testing.assert_allclose(res.std, [np.std([1, 2], ddof=1), np.std([1, 3], ddof=1)])
    np.testing.assert_allclose(res.best, [1.0, 1.0])


def test_improvement_table_percentages():
    rows = improvement_table(np.array([2.0, 0.0, 4.0]), np.array([0.5, 0.0, 5.0]), list("abc"))
    assert rows[0]["improvement_%"] == pytest.approx(75.0)
    assert np.isnan(rows[1]["improvement_%"])
    assert rows[2]["improvement_%"] == pytest.approx(-25.0)


def test_recovery_table_against_truth():
    problem = SyntheticIdentification()
    truth = problem.truth_design()
    X = truth[None, :] + np.array([[0.0] * 8, [0.1] * 8])
    X = np.clip(X, problem.space.lower, problem.space.upper)
    res = identify(X, np.abs(problem.residuals(X)), np.ones(2, bool), problem.space, top=2)
    rows = recovery_table(res, truth, problem.space)
    err = np.array([r["error"] for r in rows])
    np.testing.assert_allclose(err, X.mean(axis=0) - truth)


def test_profiles_and_local_sensitivity_find_the_planted_flat_directions():
    problem = SyntheticIdentification()
    truth = problem.truth_design()
    unit = qmc.LatinHypercube(d=8, rng=np.random.default_rng(0)).random(100)
    kept = [0, 3, 6, 8]  # one objective per planted group
    scale = objective_scale(evaluate_in_batches(problem, unit).objectives[:, kept])
    prof = profile_scan(problem, truth, kept, scale, n_points=7)
    # spare_1 and spare_2 drive no metric: their profiles are flat (exactly 0 rise),
    # except where spare_2 > 0.98 fails (NaN, ignored); every other one rises.
    names = problem.space.names
    flat = {n for n, f in zip(names, prof.flat(0.01), strict=True) if f}
    assert flat == {"spare_1", "spare_2"}
    assert prof.center_score == pytest.approx(0.0, abs=1e-12)  # truth has zero mismatch

    # signed residuals hook: the Jacobian's null space holds spare_1, spare_2, b1 - b2, d1 - d2
    sens = local_sensitivity(problem, truth, kept, scale, step=1e-3)
    assert sens.signed
    null = sens.flat_directions(1e-6)
    # the planted flat directions, exactly, in reduced row-echelon form
    expected = np.zeros((4, 8))
    expected[0, [1, 2]] = [1.0, -1.0]  # b1 - b2 (equal ranges, so equal unit-cube steps)
    expected[1, [4, 5]] = [1.0, -1.0]  # d1 - d2
    expected[2, 6] = expected[3, 7] = 1.0  # spare_1, spare_2
    np.testing.assert_allclose(null, expected, atol=1e-6)


def test_readable_basis_of_a_rotated_null_space():
    # a rotation of span{(1, -1, 0), (0, 0, 1)} comes back as those two vectors
    Q = np.array([[1.0, -1.0, 1.0], [1.0, -1.0, -1.0]])
    np.testing.assert_allclose(readable_basis(Q), [[1, -1, 0], [0, 0, 1]], atol=1e-12)


def test_fixed_rank_sum_by_hand():
    # normalisation frozen on the reference rows: columns span [1, 3] and [10, 20]
    ref = np.array([[1.0, 10.0], [3.0, 20.0], [2.0, np.nan]])
    q = FixedRankSum.fit(ref)
    np.testing.assert_allclose(q.low, [1.0, 10.0])
    np.testing.assert_allclose(q.span, [2.0, 10.0])
    # 10 * ((2 - 1)/2 + (15 - 10)/10) = 10; a row better than every reference row is < 0
    np.testing.assert_allclose(q(np.array([[2.0, 15.0], [0.0, 10.0]])), [10.0, -5.0])
    np.testing.assert_allclose(q.subset([1])(np.array([[20.0]])), [10.0])
