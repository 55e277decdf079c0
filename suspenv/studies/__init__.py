"""Studies: whole methods built from reusable steps.

:mod:`suspenv.studies.tey2014` reproduces the parameter-identification method of
Tey et al. (2014) step by step: a Latin hypercube design of experiments
(:mod:`~suspenv.studies.doe`), a Spearman sensitivity matrix
(:mod:`~suspenv.studies.sensitivity`), hierarchical clustering of the objectives
(:mod:`~suspenv.studies.clustering`), the number of clusters and one representative per
cluster (:mod:`~suspenv.studies.cluster_count`), CMA-ES on the rank-sum of the kept
objectives, the re-ranked archive and its tables (:mod:`~suspenv.studies.identification`),
the rank-sum versus Euclidean comparison (:mod:`~suspenv.studies.rank_sum`),
strategies compared on the kept objectives (:mod:`~suspenv.studies.strategy_comparison`)
and a Markdown report (:mod:`~suspenv.studies.report`). :mod:`~suspenv.studies.synthetic`
is a small identification problem with a known answer for testing the method.
"""
