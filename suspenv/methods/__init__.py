"""Methods: whole methods built from reusable steps.

:mod:`suspenv.methods.tey2014` reproduces the parameter-identification method of
Tey et al. (2014) step by step: a Latin hypercube design of experiments
(:mod:`~suspenv.methods.doe`), a Spearman sensitivity matrix
(:mod:`~suspenv.methods.sensitivity`), hierarchical clustering of the objectives
(:mod:`~suspenv.methods.clustering`), the number of clusters and one representative per
cluster (:mod:`~suspenv.methods.cluster_count`), CMA-ES on the rank-sum of the kept
objectives, the re-ranked archive and its tables (:mod:`~suspenv.methods.identification`),
the rank-sum versus Euclidean comparison (:mod:`~suspenv.methods.rank_sum`),
strategies compared on the kept objectives (:mod:`~suspenv.methods.strategy_comparison`);
its Markdown report is :mod:`suspenv.reports.tey2014`. :mod:`~suspenv.problems.synthetic`
is a small identification problem with a known answer for testing the method.
"""
