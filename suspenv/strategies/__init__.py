"""Optimisation strategies behind one ask/tell seam (see :mod:`suspenv.strategies.base`).

Each module is a small adapter over its library: ``cmaes`` (pycma), ``nsga2`` (optuna),
``random_search`` and ``lhs`` (numpy / scipy.stats.qmc); ``scalarize`` turns several
objectives into one for single-objective suspenv.strategies.
"""

from suspenv.core.scalarize import penalized_fitness, rank_sum, weighted_sum
from suspenv.strategies.base import Strategy

__all__ = ["Strategy", "penalized_fitness", "rank_sum", "weighted_sum"]
