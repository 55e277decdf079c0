"""Rank-sum versus Euclidean distance of raw mismatches (Tey et al. 2014, Figs 9-10)."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.core.scalarize import min_max_normalised
from suspenv.methods.tey2014.rank_sum import compare_rank_sum_euclidean


def test_euclidean_is_dominated_by_the_objective_in_large_units():
    # Hand-built case: objective 0 is in large units (e.g. N/mm), objectives 1-4 small
    # (e.g. deg). Design 0 is best on objective 0 only; design 1 is a good compromise.
    F = np.array(
        [
            [0.0, 1.0, 1.0, 1.0, 1.0],
            [50.0, 0.1, 0.1, 0.1, 0.1],
            [100.0, 0.5, 0.5, 0.5, 0.5],
            [200.0, 0.0, 0.0, 0.0, 0.0],
        ]
    )
    cmp = compare_rank_sum_euclidean(F)
    assert cmp.best_euclidean == 0  # sqrt(0 + 4) = 2 beats sqrt(2500.04)
    # rank-sum by hand: row 0 = 0 + 4*10 = 40; row 1 = 2.5 + 4*1 = 6.5; row 3 = 10 -> row 1
    assert cmp.rank_sum[1] == pytest.approx(6.5)
    assert cmp.best_rank_sum == 1
    assert cmp.wins_rank_sum == 4 and cmp.wins_euclidean == 1
    s = cmp.summary()
    assert s["euclidean_winner_place_by_rank_sum"] == 4  # the worst of four by rank-sum


def test_normalised_mismatch_is_min_max_to_ten():
    F = np.array([[1.0, 5.0], [3.0, 5.0], [2.0, 5.0]])
    np.testing.assert_allclose(min_max_normalised(F), [[0, 0], [10, 0], [5, 0]])


def test_failed_rows_are_dropped_and_signs_ignored():
    F = np.array([[1.0, -2.0], [np.nan, 0.0], [-0.5, 0.5]])
    cmp = compare_rank_sum_euclidean(F, names=["a", "b"])
    assert cmp.rank_sum.shape == (2,) and cmp.best_euclidean == 1 and cmp.best_rank_sum == 1
    with pytest.raises(ValidationError, match="n_valid_designs >= 2"):
        compare_rank_sum_euclidean(F[:2])
