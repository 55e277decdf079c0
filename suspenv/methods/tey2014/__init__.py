"""The parameter-identification method of Tey et al. (2014), step by step.

A Latin hypercube design of experiments (the ``lhs`` strategy), a Spearman sensitivity matrix
(:mod:`.sensitivity`), hierarchical clustering of the objectives (:mod:`.clustering`),
the number of clusters and one representative per cluster (:mod:`.cluster_count`),
CMA-ES on the rank-sum of the kept objectives and the re-ranked archive
(:mod:`.identification`), the rank-sum versus Euclidean comparison
(:mod:`.rank_sum`), strategies compared on the kept objectives
(:mod:`.strategy_comparison`), the whole pipeline (:mod:`.pipeline`); its Markdown report
is :mod:`suspenv.reports.tey2014`.
"""
