"""Core types shared by every layer: design space, batch results, the problem seam."""

from suspenv.core.errors import EvaluationError, SuspenvError, ValidationError
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.core.space import DesignSpace, Parameter

__all__ = [
    "DesignSpace",
    "EvaluationBatch",
    "EvaluationError",
    "Parameter",
    "Problem",
    "SuspenvError",
    "ValidationError",
]
