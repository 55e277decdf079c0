"""Pareto dominance against a brute-force definition."""

import numpy as np

from suspenv.core.pareto import nondominated


def _brute(F):
    # definition: i is dominated if some j is <= in every objective and < in one
    n = len(F)
    return np.array(
        [
            not any(np.all(F[j] <= F[i]) and np.any(F[j] < F[i]) for j in range(n) if j != i)
            for i in range(n)
        ]
    )


def test_matches_brute_force_with_ties_and_candidates():
    rng = np.random.default_rng(0)
    F = np.round(rng.uniform(size=(200, 3)), 1)  # coarse values: many ties
    np.testing.assert_array_equal(nondominated(F), _brute(F))
    cand = rng.uniform(size=200) < 0.5
    sub = nondominated(F, cand)
    assert not sub[~cand].any()
    np.testing.assert_array_equal(sub[cand], _brute(F[cand]))


def test_nan_rows_take_no_part():
    F = np.array([[1.0, 1.0], [np.nan, 0.0], [2.0, 0.5]])
    np.testing.assert_array_equal(nondominated(F), [True, False, True])
