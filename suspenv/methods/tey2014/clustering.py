"""Hierarchical clustering of objectives by their sensitivity vectors (Tey et al. 2014, step 3).

Each objective is a point: its vector of significant Spearman coefficients over the
parameters. Points are compared by Euclidean distance and merged agglomeratively. The
linkage (average, complete, single, weighted) is the one whose cophenetic distances
correlate best with the original distances (the cophenetic correlation coefficient).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.cluster import hierarchy
from scipy.spatial.distance import pdist, squareform

from suspenv.core.errors import ValidationError
from suspenv.methods.tey2014.sensitivity import column_names

#: the linkages compared in the paper
LINKAGE_METHODS: tuple[str, ...] = ("average", "complete", "single", "weighted")


@dataclass
class ClusteringResult:
    """The objectives' hierarchy.

    Attributes:
        features: (m, d) points clustered (one row per objective).
        names: objective names (m).
        distances: condensed Euclidean distances (m (m - 1) / 2).
        cophenetic: cophenetic correlation coefficient of each linkage tried.
        method: the linkage with the highest cophenetic correlation.
        linkage: scipy linkage matrix (m - 1, 4) of ``method``.
    """

    features: np.ndarray
    names: tuple[str, ...]
    distances: np.ndarray
    cophenetic: dict[str, float]
    method: str
    linkage: np.ndarray

    @property
    def distance_matrix(self) -> np.ndarray:
        """(m, m) square Euclidean distances."""
        return squareform(self.distances)

    def labels(self, n_clusters: int) -> np.ndarray:
        """(m,) cluster labels 0..n_clusters-1 from cutting the tree into exactly n_clusters."""
        return cut_tree(self.linkage, n_clusters)


def cut_tree(Z: np.ndarray, n_clusters: int) -> np.ndarray:
    """Labels 0..k-1 of the k-cluster cut of linkage Z, numbered by first appearance."""
    m = Z.shape[0] + 1
    if not 1 <= int(n_clusters) <= m:
        raise ValidationError(
            f"`1 <= n_clusters <= n_points` must hold, but got (n_clusters={n_clusters}, "
            f"n_points={m})"
        )
    raw = hierarchy.cut_tree(Z, n_clusters=int(n_clusters)).reshape(-1)
    _, first = np.unique(raw, return_index=True)
    order = {lab: i for i, lab in enumerate(raw[np.sort(first)])}
    return np.array([order[v] for v in raw], dtype=int)


def cophenetic_correlations(
    features: np.ndarray, methods: Sequence[str] = LINKAGE_METHODS
) -> tuple[dict[str, float], dict[str, np.ndarray], np.ndarray]:
    """Cophenetic correlation of each linkage method; also the linkages and distances."""
    D = pdist(np.asarray(features, dtype=float), metric="euclidean")
    coph: dict[str, float] = {}
    links: dict[str, np.ndarray] = {}
    for method in methods:
        Z = hierarchy.linkage(D, method=method)
        if np.ptp(D) > 0:
            c, _ = hierarchy.cophenet(Z, D)
        else:
            c = float("nan")  # all points coincide: no structure to preserve
        coph[method] = float(c)
        links[method] = Z
    return coph, links, D


def cluster_objectives(
    features: np.ndarray,
    names: Sequence[str] | None = None,
    methods: Sequence[str] = LINKAGE_METHODS,
) -> ClusteringResult:
    """Cluster the rows of ``features`` (m, d); choose the linkage by cophenetic correlation.

    Ties (and the degenerate all-equal case) go to the first method listed.
    """
    F = np.asarray(features, dtype=float)
    if F.ndim != 2 or F.shape[0] < 2:
        raise ValidationError(
            f"features must have shape (m, d) with `m >= 2`, but got {np.shape(features)}"
        )
    if not np.isfinite(F).all():
        raise ValidationError("features must be finite, but some entries are NaN or inf")
    bad = [m for m in methods if m not in LINKAGE_METHODS]
    if bad or not methods:
        raise ValidationError(
            f"linkage methods must be a non-empty subset of {LINKAGE_METHODS}, but got "
            f"{list(methods)}"
        )
    nm = column_names(names, F.shape[0])
    coph, links, D = cophenetic_correlations(F, methods)
    scores = [(-np.inf if np.isnan(coph[m]) else coph[m]) for m in methods]
    best = list(methods)[int(np.argmax(scores))]
    return ClusteringResult(F, nm, D, coph, best, links[best])
