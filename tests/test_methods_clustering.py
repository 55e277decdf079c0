"""Hierarchical clustering, silhouette and the rank method on planted groups."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.cluster import hierarchy
from scipy.spatial.distance import pdist, squareform

from suspenv.core.errors import ValidationError
from suspenv.methods.tey2014.cluster_count import (
    rank_method,
    representatives,
    select_objectives,
    silhouette_samples,
)
from suspenv.methods.tey2014.clustering import LINKAGE_METHODS, cluster_objectives, cut_tree


def _planted_groups(sizes=(6, 4, 5), spread=0.03, seed=0):
    """Points around well-separated centres; returns features and true labels."""
    rng = np.random.default_rng(seed)
    centres = np.eye(len(sizes), 6) * 2.0
    feats, labels = [], []
    for g, n in enumerate(sizes):
        feats.append(centres[g] + spread * rng.normal(size=(n, 6)))
        labels += [g] * n
    return np.vstack(feats), np.array(labels)


def _same_partition(a, b):
    # two labelings are the same partition when the pair co-membership matrices agree
    return np.array_equal(a[:, None] == a[None, :], b[:, None] == b[None, :])


def test_planted_groups_are_recovered_by_every_linkage():
    X, truth = _planted_groups()
    res = cluster_objectives(X)
    assert set(res.cophenetic) == set(LINKAGE_METHODS)
    for method in LINKAGE_METHODS:
        Z = hierarchy.linkage(pdist(X), method=method)
        assert _same_partition(cut_tree(Z, 3), truth)
    assert _same_partition(res.labels(3), truth)


def test_cophenetic_choice_matches_scipy_and_picks_the_maximum():
    # reference: scipy.cluster.hierarchy.cophenet on each linkage separately
    rng = np.random.default_rng(4)
    X = rng.normal(size=(15, 5))
    res = cluster_objectives(X)
    D = pdist(X)
    for method in LINKAGE_METHODS:
        ref, _ = hierarchy.cophenet(hierarchy.linkage(D, method=method), D)
        assert res.cophenetic[method] == pytest.approx(ref)
    assert res.cophenetic[res.method] == max(res.cophenetic.values())


def test_silhouette_matches_hand_calculation():
    # hand calculation on a line: points 0, 1 (cluster 0) and 5 (cluster 1), 6, 7 (cluster 1)
    x = np.array([0.0, 1.0, 5.0, 6.0, 7.0])
    D = np.abs(x[:, None] - x[None, :])
    labels = np.array([0, 0, 1, 1, 1])
    s = silhouette_samples(D, labels)
    # point 0: a = 1, b = mean(5, 6, 7) = 6 -> s = 5/6
    assert s[0] == pytest.approx(5 / 6)
    # point 2 (x=5): a = mean(1, 2) = 1.5, b = mean(5, 4) = 4.5 -> s = 3/4.5
    assert s[2] == pytest.approx(3 / 4.5)
    # singletons: 0 by Rousseeuw's convention, or the chosen value
    lab = np.array([0, 0, 1, 1, 2])
    assert silhouette_samples(D, lab)[4] == 0.0
    assert silhouette_samples(D, lab, singleton_value=1.0)[4] == 1.0


def test_silhouette_and_rank_method_find_the_planted_number_of_clusters():
    for sizes in [(6, 4, 5), (3, 3, 3, 3, 4)]:
        X, truth = _planted_groups(sizes)
        sel = select_objectives(cluster_objectives(X), criterion="rank")
        k_true = len(sizes)
        assert sel.k_silhouette == k_true
        assert sel.k_rank == k_true
        assert sel.k == k_true and _same_partition(sel.labels, truth)
        assert sel.silhouette_at(k_true) > 0.9
        # one representative per planted group
        assert sorted(truth[sel.kept]) == list(range(k_true))


def test_rank_method_formula():
    # RS = (max s - s)/(max s - min s), RC = (C - min C)/(max C - min C); paper's definition
    ks = [2, 3, 4, 5]
    s = [0.5, 0.9, 0.95, 0.7]
    score = rank_method(ks, s)
    np.testing.assert_allclose(
        score, [0.45 / 0.45 + 0, 0.05 / 0.45 + 1 / 3, 0 + 2 / 3, 0.25 / 0.45 + 1]
    )
    assert ks[int(np.argmin(score))] == 3  # fewer clusters win when quality is close


def test_representative_rules():
    # cluster 0: three points on a line -> medoid is the middle one;
    # the most sensitive is the one with the largest |coefficients|
    F = np.array([[0.1, 0.0], [0.5, 0.0], [0.9, 0.0], [0.0, -3.0]])
    labels = np.array([0, 0, 0, 1])
    assert list(representatives(F, labels, "medoid")) == [1, 3]
    assert list(representatives(F, labels, "most_sensitive")) == [2, 3]
    with pytest.raises(ValidationError, match="representative rule"):
        representatives(F, labels, "first")


def test_identical_vectors_cluster_together():
    # objectives with identical Spearman vectors (e.g. a gradient and its value) are one cluster
    X = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 1.0], [0.7, 0.7]])
    res = cluster_objectives(X)
    lab = res.labels(3)
    assert lab[0] == lab[1] and lab[2] == lab[3] and len(set(lab)) == 3
    assert squareform(res.distances)[0, 1] == 0.0


def test_bad_input():
    with pytest.raises(ValidationError, match="m >= 2"):
        cluster_objectives(np.zeros((1, 3)))
    with pytest.raises(ValidationError, match="linkage methods"):
        cluster_objectives(np.eye(3), methods=["ward"])
    with pytest.raises(ValidationError, match="k_min"):
        select_objectives(cluster_objectives(np.eye(4)), k_min=1)


def test_silhouette_matches_a_brute_force_loop_on_random_data():
    # reference: Rousseeuw's definition evaluated point by point with plain loops
    rng = np.random.default_rng(7)
    X = rng.normal(size=(25, 3))
    D = squareform(pdist(X))
    labels = rng.integers(0, 4, size=25)
    labels[:4] = [0, 1, 2, 3]  # every label present
    want = []
    for i in range(25):
        own = [j for j in range(25) if labels[j] == labels[i] and j != i]
        if not own:
            want.append(0.0)
            continue
        a = np.mean([D[i, j] for j in own])
        b = min(
            np.mean([D[i, j] for j in range(25) if labels[j] == c])
            for c in set(labels.tolist()) - {labels[i]}
        )
        want.append((b - a) / max(a, b))
    np.testing.assert_allclose(silhouette_samples(D, labels), want, atol=1e-12)


def test_every_cut_has_exactly_k_clusters():
    rng = np.random.default_rng(2)
    res = cluster_objectives(rng.normal(size=(12, 4)))
    for k in range(1, 13):
        lab = res.labels(k)
        assert sorted(set(lab)) == list(range(k))
