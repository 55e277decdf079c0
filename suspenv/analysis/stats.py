"""Rank tests on final qualities across seeds (lower is better).

Protocol (stated in every result):

1. With three or more groups that share the same seeds, a Friedman test first
   (``scipy.stats.friedmanchisquare``; blocks are the seeds, treatments the groups).
2. Every pair of groups: a two-sided Mann-Whitney U test (``scipy.stats.mannwhitneyu``,
   exact distribution for small samples without ties, normal approximation otherwise),
   p-values adjusted over all pairs by Holm-Bonferroni (step-down).
3. A pair is called different when its adjusted p is below ``alpha`` and, if a Friedman
   test was run, it rejected too. A pair whose smallest attainable adjusted p is above
   ``alpha`` (too few seeds: with 3 runs against 3 the exact two-sided p cannot go below
   2 / C(6, 3) = 0.1) is reported as "not separable with n seeds", never as "equal".

Runs without a feasible value have quality ``+inf`` (ranked last, ties among themselves).
The effect size is ``A12 = P(a < b) + P(a = b) / 2`` (Vargha and Delaney), the
probability that a run of the first group beats one of the second.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from itertools import combinations
from math import comb
from typing import Any

import numpy as np

from suspenv.core.options import number

CORRECTION = "Holm-Bonferroni over all pairs"


def holm(pvalues: Sequence[float]) -> np.ndarray:
    """Holm-Bonferroni adjusted p-values: with p sorted ascending,
    ``p_adj(i) = max_{j <= i} min(1, (k - j + 1) p(j))`` (1-based ranks), in input order."""
    p = np.asarray(pvalues, dtype=float)
    k = p.size
    if not k:
        return p
    order = np.argsort(p, kind="stable")
    adj = np.minimum(1.0, (k - np.arange(k)) * p[order])
    adj = np.maximum.accumulate(adj)
    out = np.empty(k)
    out[order] = adj
    return out


def min_two_sided_p(n1: int, n2: int) -> float:
    """Smallest two-sided p-value the exact Mann-Whitney test can give: ``2 / C(n1+n2, n1)``
    (complete separation, no ties), at most 1."""
    if n1 < 1 or n2 < 1:
        return 1.0
    return min(1.0, 2.0 / comb(n1 + n2, n1))


def min_holm_p(n_groups: int, n_seeds: int) -> float:
    """Smallest Holm-adjusted p the pairwise tests of ``n_groups`` groups with ``n_seeds``
    runs each can give: Holm multiplies the smallest p by the number of pairs, so
    ``C(n_groups, 2) * 2 / C(2 n_seeds, n_seeds)``, at most 1 (1 for fewer than 2 groups).
    Below ``alpha`` is needed for any pair to be told apart."""
    pairs = comb(n_groups, 2)
    return min(1.0, pairs * min_two_sided_p(n_seeds, n_seeds)) if pairs else 1.0


def seeds_needed(n_groups: int, alpha: float) -> int:
    """The fewest seeds per group with :func:`min_holm_p` below ``alpha`` (1 for fewer
    than two groups: nothing to tell apart)."""
    number("rank tests", "alpha", alpha, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    if n_groups < 2:
        return 1
    n = 1
    while min_holm_p(n_groups, n) >= alpha:
        n += 1
    return n


def _finite_for_ranks(x: np.ndarray, big: float) -> np.ndarray:
    return np.where(np.isfinite(x), x, big)


def a12(x: np.ndarray, y: np.ndarray) -> float:
    """``P(x < y) + P(x = y) / 2`` over all pairs (lower is better: x beats y)."""
    x = np.asarray(x, dtype=float)[:, None]
    y = np.asarray(y, dtype=float)[None, :]
    return float(((x < y) + 0.5 * (x == y)).mean())


def _friedman(
    data: dict[str, np.ndarray], seeds: Mapping[str, Sequence[int]], big: float, alpha: float
) -> dict[str, Any]:
    """The Friedman test over three or more groups paired by seed (``rank_tests``'s
    ``friedman``), or why it was skipped."""
    from scipy import stats

    labels = list(data)
    seed_sets = [tuple(sorted(seeds[k])) for k in labels]
    common = seed_sets[0]
    if not (
        all(s == common for s in seed_sets) and len(common) >= 2 and len(set(common)) == len(common)
    ):
        return {
            "skipped": "groups do not share one set of distinct seeds (>= 2), so runs "
            "cannot be paired by seed"
        }
    columns = []
    for k in labels:
        by_seed = dict(zip(seeds[k], data[k], strict=True))
        columns.append(_finite_for_ranks(np.array([by_seed[s] for s in common]), big))
    if all(np.ptp(np.vstack(columns), axis=0) == 0):
        stat, p = 0.0, 1.0  # every seed ties every group
    else:
        res = stats.friedmanchisquare(*columns)
        stat, p = float(res.statistic), float(res.pvalue)
    return {
        "statistic": stat,
        "p": p,
        "groups": labels,
        "seeds": list(common),
        "rejects": p < alpha,
    }


def _mann_whitney(x: np.ndarray, y: np.ndarray, big: float) -> tuple[float, float]:
    """(U, two-sided p) of two groups' finals; (n_x n_y / 2, 1) when either is empty or
    both hold one and the same value."""
    from scipy import stats

    if (
        len(x)
        and len(y)
        and not (np.array_equal(np.unique(x), np.unique(y)) and np.unique(x).size == 1)
    ):
        res = stats.mannwhitneyu(
            _finite_for_ranks(x, big), _finite_for_ranks(y, big), alternative="two-sided"
        )
        return float(res.statistic), float(res.pvalue)
    return float(len(x) * len(y)) / 2.0, 1.0


def _verdict(
    a: str,
    b: str,
    n: tuple[int, int],
    eff: float,
    p_holm: float,
    floor: float,
    alpha: float,
    friedman_rejects: bool,
) -> str:
    """What a pair's test says, in words (``floor``: the smallest attainable adjusted p)."""
    if floor >= alpha:
        return (
            f"not separable with {n[0]} and {n[1]} seeds: the smallest attainable "
            f"adjusted p is {floor:.3g} >= alpha {alpha:g}"
        )
    if p_holm < alpha and friedman_rejects:
        return f"{a if eff > 0.5 else b} better (p_holm = {p_holm:.3g})"
    if p_holm < alpha:
        return "pairwise p_holm < alpha, but the Friedman test did not reject"
    return f"no difference detected (p_holm = {p_holm:.3g})"


def rank_tests(
    samples: Mapping[str, Sequence[float]],
    seeds: Mapping[str, Sequence[int]] | None = None,
    alpha: float = 0.05,
) -> dict[str, Any]:
    """Friedman (when applicable) and pairwise Mann-Whitney with Holm correction.

    ``samples``: group label -> final qualities (one per run; None/NaN/inf: no feasible
    value, ranked last). ``seeds``: group label -> the runs' seeds (for the Friedman
    pairing; without it no Friedman test). Returns a JSON-ready dict: ``friedman`` (None
    or statistic, p, seeds), ``pairs`` (a, b, n_a, n_b, median_a, median_b, U, p,
    p_holm, a12, min_attainable_p, verdict), ``alpha``, ``correction``, ``protocol``.
    """
    number("rank tests", "alpha", alpha, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    data = {
        k: np.array([np.inf if v is None or np.isnan(v) else float(v) for v in vals])
        for k, vals in samples.items()
    }
    labels = list(data)
    finite = [v for a in data.values() for v in a[np.isfinite(a)]]
    big = (max(finite) + 1.0 + abs(max(finite))) if finite else 1.0
    out: dict[str, Any] = {
        "alpha": alpha,
        "correction": CORRECTION,
        "protocol": (
            "Friedman test over the groups first when there are >= 3 groups with the same "
            "seeds; two-sided Mann-Whitney U per pair, Holm-Bonferroni adjusted; a pair "
            "differs when p_holm < alpha (and the Friedman test, if run, rejected)"
        ),
        "friedman": None,
        "pairs": [],
    }
    if seeds is not None and len(labels) >= 3:
        out["friedman"] = _friedman(data, seeds, big, alpha)
    friedman_rejects = (out["friedman"] or {}).get("rejects", True)
    pairs = list(combinations(labels, 2))
    raw = [_mann_whitney(data[a], data[b], big) for a, b in pairs]
    adjusted = holm([p for _, p in raw])
    # Holm multiplies the smallest p by the number of pairs and never lets a later one
    # fall below it: no adjusted p goes below max(own floor, pairs * smallest floor)
    floors = [min_two_sided_p(len(data[a]), len(data[b])) for a, b in pairs]
    overall = len(pairs) * min(floors) if floors else 1.0
    for (a, b), (u, p), ph, own in zip(pairs, raw, adjusted, floors, strict=True):
        x, y = data[a], data[b]
        floor = min(1.0, max(own, overall))
        eff = a12(x, y) if len(x) and len(y) else float("nan")
        out["pairs"].append(
            {
                "a": a,
                "b": b,
                "n_a": len(x),
                "n_b": len(y),
                "median_a": float(np.median(x)) if len(x) else None,
                "median_b": float(np.median(y)) if len(y) else None,
                "U": u,
                "p": p,
                "p_holm": float(ph),
                "a12": eff,
                "min_attainable_p_holm": floor,
                "verdict": _verdict(
                    a, b, (len(x), len(y)), eff, ph, floor, alpha, friedman_rejects
                ),
            }
        )
    return out


def seed_plan(
    n_strategies: int, seeds: Sequence[int] | None, alpha: float = 0.05
) -> tuple[list[int], str]:
    """The seeds of a suite run and what they can tell apart, said before running.

    ``seeds`` None: seeds 1..n with n the larger of 5 and the fewest that let the rank
    tests separate ``n_strategies`` strategies at ``alpha`` after Holm's correction
    (:func:`seeds_needed`). Given seeds are kept; the message
    then says whether they can."""
    need = seeds_needed(n_strategies, alpha)
    chosen = list(seeds) if seeds is not None else list(range(1, max(5, need) + 1))
    n = len(chosen)
    floor = min_holm_p(n_strategies, n)
    if n_strategies < 2:
        return chosen, f"{n} seed(s), one strategy: no rank test"
    head = (
        f"{n_strategies} strategies with {n} seeds each: the smallest attainable "
        f"Holm-adjusted p of the pairwise rank tests is {floor:.3g}"
    )
    if floor < alpha:
        return chosen, f"{head} < alpha {alpha:g}: they can be told apart"
    return chosen, (
        f"{head} >= alpha {alpha:g}: no pair can be told apart; {need} seeds are needed"
    )
