"""Spearman sensitivity matrix on data with planted monotone relations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from suspenv.core.errors import ValidationError
from suspenv.methods.tey2014.sensitivity import spearman_matrix


def _planted(n=300, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, 4))
    F = np.column_stack(
        [
            np.exp(3 * X[:, 0]),  # perfectly increasing in x0 -> rho = +1
            -(X[:, 1] ** 3),  # perfectly decreasing in x1 -> rho = -1
            X[:, 2] + 0.3 * rng.normal(size=n),  # noisy increasing in x2
            rng.normal(size=n),  # unrelated to everything
        ]
    )
    return X, F


def test_planted_monotone_relations_are_found():
    X, F = _planted()
    res = spearman_matrix(X, F)
    # a strictly monotone function has Spearman +-1 (definition of rank correlation)
    assert res.rho[0, 0] == pytest.approx(1.0)
    assert res.rho[1, 1] == pytest.approx(-1.0)
    assert res.rho[2, 2] > 0.5 and res.significant[2, 2]
    # x3 drives nothing; f3 depends on nothing: nothing significant there (alpha = 0.05,
    # so a chance false positive is possible but not for this seed)
    assert not res.significant[3].any()
    assert not res.significant[:, 3].any()
    assert res.insensitive_parameters() == ["x3"]
    assert np.all(res.rho_significant[~res.significant] == 0.0)


def test_matches_scipy_spearmanr_with_ties_and_failed_rows():
    # independent reference: scipy.stats.spearmanr, one pair at a time
    rng = np.random.default_rng(1)
    X = rng.integers(0, 5, size=(60, 3)).astype(float)  # many ties
    F = np.column_stack([X[:, 0] + rng.normal(size=60), rng.normal(size=60)])
    F[[4, 9], 1] = np.nan  # failed evaluations are dropped before ranking
    res = spearman_matrix(X, F, alpha=0.05)
    keep = np.isfinite(F).all(axis=1)
    for i in range(3):
        for j in range(2):
            ref = stats.spearmanr(X[keep, i], F[keep, j])
            assert res.rho[i, j] == pytest.approx(ref.statistic, abs=1e-12)
            assert res.pvalue[i, j] == pytest.approx(ref.pvalue, rel=1e-9, abs=1e-14)
    assert res.n_samples == 58


def test_constant_column_means_no_correlation():
    X = np.column_stack([np.arange(10.0), np.ones(10)])
    F = np.arange(10.0)[:, None]
    res = spearman_matrix(X, F)
    assert res.rho[1, 0] == 0.0 and res.pvalue[1, 0] == 1.0


def test_bad_input_names_the_rule():
    with pytest.raises(ValidationError, match="0 < alpha < 1"):
        spearman_matrix(np.zeros((10, 2)), np.zeros((10, 1)), alpha=1.5)
    with pytest.raises(ValidationError, match="same number of rows"):
        spearman_matrix(np.zeros((10, 2)), np.zeros((9, 1)))
