"""Number of clusters and one representative objective per cluster (Tey et al. 2014, step 4).

The mean silhouette s(k) is computed for every candidate number of clusters k. The
paper's rank method then balances quality against count:
``RS_k = (max s - s_k) / (max s - min s)``, ``RC_k = (k - min k) / (max k - min k)``,
and chooses the k with the smallest ``RS_k + RC_k`` (ties: the smaller k).

Silhouette of point i (Rousseeuw 1987): ``s_i = (b_i - a_i) / max(a_i, b_i)`` with a_i the
mean distance to the other members of its cluster and b_i the smallest mean distance to
another cluster. A point alone in its cluster has no a_i; by Rousseeuw's convention its
s_i is 0 (``singleton_value``); some tools use 1 (a_i taken as 0), which favours many
clusters. When two points coincide (a_i = b_i = 0), s_i = 0.

Representative rules (one objective kept per cluster):
- ``"medoid"``: the member with the smallest mean distance to the other members; ties go
  to the member with the largest sum of |significant Spearman coefficients|.
- ``"most_sensitive"``: the member with the largest sum of |coefficients| (the one that
  carries the strongest signal about the parameters); ties go to the first listed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.methods.tey2014.clustering import ClusteringResult

REPRESENTATIVE_RULES = ("medoid", "most_sensitive")
CRITERIA = ("rank", "silhouette")


def silhouette_samples(
    D: np.ndarray, labels: np.ndarray, singleton_value: float = 0.0
) -> np.ndarray:
    """(m,) silhouette of each point, from a square distance matrix D (m, m)."""
    D = np.asarray(D, dtype=float)
    labels = np.asarray(labels)
    m = D.shape[0]
    if D.shape != (m, m) or labels.shape != (m,):
        raise ValidationError(
            f"D must be square (m, m) and labels (m,), but got (D={D.shape}, labels={labels.shape})"
        )
    uniq, lab = np.unique(labels, return_inverse=True)
    k = uniq.size
    if not 2 <= k <= m - 1 and m > 2:
        raise ValidationError(
            f"silhouette needs `2 <= n_clusters <= n_points - 1`, but got (n_clusters={k}, "
            f"n_points={m})"
        )
    onehot = np.zeros((m, k))
    onehot[np.arange(m), lab] = 1.0
    sizes = onehot.sum(axis=0)
    sums = D @ onehot  # (m, k): sum of distances of i to the members of each cluster
    own = sizes[lab]
    a = np.where(own > 1, sums[np.arange(m), lab] / np.maximum(own - 1, 1), 0.0)
    mean_other = sums / sizes
    mean_other[np.arange(m), lab] = np.inf
    b = mean_other.min(axis=1)
    denom = np.maximum(a, b)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(denom > 0, (b - a) / np.where(denom > 0, denom, 1.0), 0.0)
    return np.where(own > 1, s, float(singleton_value))


def rank_method(
    n_clusters: Sequence[int] | np.ndarray, mean_silhouette: Sequence[float] | np.ndarray
) -> np.ndarray:
    """RS_k + RC_k for every candidate k (smaller is better)."""
    C = np.asarray(n_clusters, dtype=float)
    s = np.asarray(mean_silhouette, dtype=float)
    if C.shape != s.shape or C.size == 0:
        raise ValidationError(
            f"n_clusters and mean_silhouette must have the same non-zero length, but got "
            f"({C.size}, {s.size})"
        )
    s_span = s.max() - s.min()
    c_span = C.max() - C.min()
    RS = (s.max() - s) / s_span if s_span > 0 else np.zeros_like(s)
    RC = (C - C.min()) / c_span if c_span > 0 else np.zeros_like(C)
    return RS + RC


def representatives(features: np.ndarray, labels: np.ndarray, rule: str = "medoid") -> np.ndarray:
    """Index of one representative per cluster (ordered by label 0..k-1)."""
    if rule not in REPRESENTATIVE_RULES:
        raise ValidationError(
            f"representative rule must be one of {REPRESENTATIVE_RULES}, but got {rule!r}"
        )
    F = np.asarray(features, dtype=float)
    labels = np.asarray(labels)
    strength = np.abs(F).sum(axis=1)
    out = []
    for lab in np.unique(labels):
        members = np.flatnonzero(labels == lab)
        if rule == "most_sensitive" or members.size == 1:
            out.append(members[np.argmax(strength[members])])
            continue
        sub = F[members]
        mean_d = np.sqrt(((sub[:, None, :] - sub[None, :, :]) ** 2).sum(-1)).sum(1) / (
            members.size - 1
        )
        near = np.isclose(mean_d, mean_d.min(), rtol=1e-9, atol=1e-12)
        cand = members[near]
        out.append(cand[np.argmax(strength[cand])])
    return np.array(out, dtype=int)


@dataclass
class ClusterSelection:
    """The chosen number of clusters and the kept objectives.

    Attributes:
        n_clusters: candidate numbers of clusters k.
        mean_silhouette: mean silhouette of each k.
        rank_score: RS + RC of each k.
        k_silhouette: k with the highest mean silhouette (smallest on ties).
        k_rank: k with the smallest RS + RC (smallest on ties).
        criterion: which of the two was used ("rank" or "silhouette").
        k: the chosen number of clusters.
        labels: (m,) cluster of each objective at k.
        kept: indices of the kept objectives (one per cluster).
        rule: representative rule used.
        names: objective names.
    """

    n_clusters: np.ndarray
    mean_silhouette: np.ndarray
    rank_score: np.ndarray
    k_silhouette: int
    k_rank: int
    criterion: str
    k: int
    labels: np.ndarray
    kept: np.ndarray
    rule: str
    names: tuple[str, ...]
    singleton_value: float

    @property
    def kept_names(self) -> tuple[str, ...]:
        return tuple(self.names[i] for i in self.kept)

    def silhouette_at(self, k: int) -> float:
        return float(self.mean_silhouette[list(self.n_clusters).index(k)])

    def clusters(self) -> list[list[str]]:
        """Objective names of each cluster, ordered by label."""
        return [[self.names[i] for i in np.flatnonzero(self.labels == c)] for c in range(self.k)]


def select_objectives(
    clustering: ClusteringResult,
    k_min: int = 2,
    k_max: int | None = None,
    criterion: str = "rank",
    rule: str = "medoid",
    singleton_value: float = 0.0,
) -> ClusterSelection:
    """Choose the number of clusters of ``clustering`` and one objective per cluster."""
    m = clustering.features.shape[0]
    if m < 3:
        raise ValidationError(
            f"choosing a number of clusters needs `m >= 3` objectives, but got m={m}"
        )
    if criterion not in CRITERIA:
        raise ValidationError(f"criterion must be one of {CRITERIA}, but got {criterion!r}")
    k_max = m - 1 if k_max is None else int(k_max)
    if not 2 <= int(k_min) <= k_max <= m - 1:
        raise ValidationError(
            f"`2 <= k_min <= k_max <= m - 1` must hold, but got (k_min={k_min}, k_max={k_max}, "
            f"m={m})"
        )
    D = clustering.distance_matrix
    ks = np.arange(int(k_min), k_max + 1)
    sil = np.array(
        [silhouette_samples(D, clustering.labels(k), singleton_value).mean() for k in ks]
    )
    score = rank_method(ks, sil)
    k_sil = int(ks[np.argmax(sil)])
    k_rank = int(ks[np.argmin(score)])
    k = k_rank if criterion == "rank" else k_sil
    labels = clustering.labels(k)
    kept = representatives(clustering.features, labels, rule)
    return ClusterSelection(
        ks,
        sil,
        score,
        k_sil,
        k_rank,
        criterion,
        k,
        labels,
        kept,
        rule,
        clustering.names,
        float(singleton_value),
    )
