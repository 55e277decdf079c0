"""Rank-sum versus Euclidean distance as the pseudo-objective (Tey et al. 2014, Figs 9-10).

Over a set of designs (the paper: 100 random ones) each design gets two scores from its
mismatch vector: the dynamic rank-sum (every objective min-max normalised to [0, 10] over
the set, then summed; :func:`suspenv.core.scalarize.rank_sum`) and the Euclidean norm of the
raw mismatches. Each score picks a winner. The comparison shows, objective by objective,
the normalised mismatch [0, 10] of both winners: raw Euclidean distance is dominated by
the objectives with the largest numbers (units), the rank-sum weighs every objective alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.scalarize import min_max_normalised, rank_sum
from suspenv.methods.tey2014.sensitivity import column_names


@dataclass
class ScalarisationComparison:
    """The two winners among the same designs.

    Attributes:
        rank_sum, euclidean: (n,) score of every design under each criterion.
        best_rank_sum, best_euclidean: row index of each winner.
        normalised: (n, m) mismatches normalised to [0, 10] over the set.
        names: objective names.
        wins_rank_sum, wins_euclidean, ties: objectives on which each winner is better.
    """

    rank_sum: np.ndarray
    euclidean: np.ndarray
    best_rank_sum: int
    best_euclidean: int
    normalised: np.ndarray
    names: tuple[str, ...]

    @property
    def winner_profiles(self) -> tuple[np.ndarray, np.ndarray]:
        """Normalised mismatch (m,) of the rank-sum winner and of the Euclidean winner."""
        return self.normalised[self.best_rank_sum], self.normalised[self.best_euclidean]

    @property
    def wins_rank_sum(self) -> int:
        a, b = self.winner_profiles
        return int((a < b).sum())

    @property
    def wins_euclidean(self) -> int:
        a, b = self.winner_profiles
        return int((b < a).sum())

    @property
    def ties(self) -> int:
        a, b = self.winner_profiles
        return int((a == b).sum())

    def summary(self) -> dict[str, float | int]:
        a, b = self.winner_profiles
        n = self.rank_sum.size
        # place of each winner under the other criterion (1 = best)
        place_rs_in_eu = int((self.euclidean < self.euclidean[self.best_rank_sum]).sum()) + 1
        place_eu_in_rs = int((self.rank_sum < self.rank_sum[self.best_euclidean]).sum()) + 1
        return {
            "n_designs": n,
            "rank_sum_winner_row": self.best_rank_sum,
            "euclidean_winner_row": self.best_euclidean,
            "objectives_better_with_rank_sum_winner": self.wins_rank_sum,
            "objectives_better_with_euclidean_winner": self.wins_euclidean,
            "objectives_tied": self.ties,
            "mean_normalised_mismatch_rank_sum_winner": float(a.mean()),
            "mean_normalised_mismatch_euclidean_winner": float(b.mean()),
            "worst_normalised_mismatch_rank_sum_winner": float(a.max()),
            "worst_normalised_mismatch_euclidean_winner": float(b.max()),
            "rank_sum_winner_place_by_euclidean": place_rs_in_eu,
            "euclidean_winner_place_by_rank_sum": place_eu_in_rs,
        }


def compare_rank_sum_euclidean(
    F: np.ndarray, names: Sequence[str] | None = None
) -> ScalarisationComparison:
    """Compare the two pseudo-objectives on the mismatch matrix F (n, m) of n designs.

    Rows that are not finite (failed designs) are dropped first; returned row indices
    refer to the finite rows only. Mismatches are taken as magnitudes (|F|).
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 2 or F.shape[1] < 1:
        raise ValidationError(f"F must have shape (n, m), but got {F.shape}")
    F = np.abs(F[np.isfinite(F).all(axis=1)])
    if F.shape[0] < 2:
        raise ValidationError(
            f"the comparison needs `n_valid_designs >= 2`, but got n_valid_designs={F.shape[0]}"
        )
    nm = column_names(names, F.shape[1])
    rs = rank_sum(F)
    eu = np.sqrt((F**2).sum(axis=1))
    return ScalarisationComparison(
        rs, eu, int(np.argmin(rs)), int(np.argmin(eu)), min_max_normalised(F), nm
    )
