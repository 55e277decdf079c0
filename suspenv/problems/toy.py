"""Analytic test problems for smoke tests and overhead benchmarks (no physics)."""

from __future__ import annotations

import time

import numpy as np

from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import EvaluationError
from suspenv.core.options import integer, number


class Sphere(Problem):
    """f(x) = sum((x - 0.3)^2) on [-1, 1]^d; minimum 0 at x = 0.3. Trivial and cheap."""

    name = "Sphere"
    description = "sum of squares, d variables (framework smoke tests and overhead benchmark)"

    def __init__(self, dim: int = 10, delay_s: float = 0.0):
        """``dim``: number of variables, an integer >= 1; ``delay_s`` [s]: a sleep per
        batch (stands in for an expensive simulation), finite and >= 0."""
        self.dim = integer(self.name, "dim", dim, lo=1)
        self.delay_s = number(self.name, "delay_s", delay_s, lo=0.0)
        self.space = DesignSpace(Parameter(f"x{i}", -1.0, 1.0) for i in range(self.dim))
        self.objective_names = ("f",)

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        if self.delay_s:
            time.sleep(self.delay_s)
        if not np.isfinite(X).all() or np.any(np.abs(X) > 1.0):
            raise EvaluationError("Sphere: design outside [-1, 1]")
        f = ((X - 0.3) ** 2).sum(axis=1, keepdims=True)
        n = X.shape[0]
        return EvaluationBatch(f, np.zeros((n, 0)), np.ones(n, bool), [""] * n)

    def config(self) -> dict:
        return {"dim": self.dim, "delay_s": self.delay_s}


class ZDT1(Problem):
    """Zitzler-Deb-Thiele ZDT1, two objectives; Pareto front f2 = 1 - sqrt(f1) at x[1:] = 0."""

    name = "ZDT1"
    description = "ZDT1 bi-objective test function (multi-objective smoke tests)"

    def __init__(self, dim: int = 6):
        """``dim``: number of variables, an integer >= 2."""
        self.dim = integer(self.name, "dim", dim, lo=2)
        self.space = DesignSpace(Parameter(f"x{i}", 0.0, 1.0) for i in range(self.dim))
        self.objective_names = ("f1", "f2")

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        f1 = X[:, 0]
        g = 1.0 + 9.0 * X[:, 1:].sum(axis=1) / (self.dim - 1)
        f2 = g * (1.0 - np.sqrt(f1 / g))
        n = X.shape[0]
        return EvaluationBatch(np.c_[f1, f2], np.zeros((n, 0)), np.ones(n, bool), [""] * n)

    def config(self) -> dict:
        return {"dim": self.dim}

    @staticmethod
    def pareto_front(n: int) -> np.ndarray:
        """``n`` points ``(f1, f2)`` of the Pareto front ``f2 = 1 - sqrt(f1)``, f1 evenly
        spaced in [0, 1] (the front is the same for every ``dim``)."""
        f1 = np.linspace(0.0, 1.0, int(n))
        return np.c_[f1, 1.0 - np.sqrt(f1)]
