"""Strategies survive generations in which every design fails.

CMA-ES used to end at the first such generation (pycma saw a flat fitness and met its
``tolfun`` criterion): now it widens its step size and goes on, and stops only after
``max_failed_generations`` of them in a row, saying so. NSGA-II (optuna and pymoo) keeps
the population it had; random search and the Latin hypercube do not look at results.
"""

from __future__ import annotations

import numpy as np
import pytest

from suspenv import make_problem
from suspenv.core import EvaluationBatch
from suspenv.problems.toy import Sphere
from suspenv.registry import make_strategy

#: Sphere's optimum x = 0.3 on [-1, 1] is u = 0.65 in the unit cube (closed form)
OPTIMUM_U = 0.65


class HoleSphere(Sphere):
    """Sphere whose designs with every |x_j| < 0.2 (unit cube: 0.4 < u < 0.6, around
    CMA-ES's default start 0.5) fail; the optimum u = 0.65 lies outside the hole."""

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        batch = super()._evaluate(X)
        bad = np.all(np.abs(X) < 0.2, axis=1)
        batch.ok = batch.ok & ~bad
        batch.objectives[bad] = np.nan
        batch.messages = ["LockupError: in the hole" if b else "" for b in bad]
        return batch


def failed(U: np.ndarray, m: int = 1, message: str = "ConvergenceError: no") -> EvaluationBatch:
    return EvaluationBatch.failed(len(U), m, 0, message)


def run(strategy, tell, generations: int) -> list[np.ndarray]:
    """Ask/tell ``generations`` times (``tell(g, U) -> batch``); the asked arrays."""
    asked = []
    for g in range(generations):
        if strategy.stop():
            break
        U = strategy.ask()
        asked.append(U)
        strategy.tell(U, tell(g, U))
    return asked


# ------------------------------------------------------------------------ CMA-ES
def test_cmaes_widens_out_of_a_failing_region_and_reaches_the_optimum():
    problem = HoleSphere(dim=4)
    s = make_strategy("cmaes", problem, seed=3, popsize=8, sigma0=0.02)
    U = s.ask()
    first = problem.evaluate_unit(U)
    assert not first.ok.any()  # sigma0 = 0.02: the whole first generation is in the hole
    s.tell(U, first)
    assert s.stop() is None  # it used to stop here: "cma: tolfun=1e-11"
    assert s.failed_generations == 1
    run(s, lambda g, U: problem.evaluate_unit(U), 200)
    assert s.failed_generations_total >= 1 and s.failed_generations == 0
    np.testing.assert_allclose(s.mean, OPTIMUM_U, atol=1e-3)
    assert s.stop() is not None and "tolfun" in s.stop()  # converged, not given up


def test_cmaes_goes_on_after_k_failed_generations_and_widens_its_step():
    problem = make_problem("Sphere", dim=4)
    k = 3
    s = make_strategy("cmaes", problem, seed=5, popsize=10, sigma0=0.05)
    asked = run(s, lambda g, U: failed(U) if g < k else problem.evaluate_unit(U), 150)
    assert len(asked) > 20
    np.testing.assert_allclose(s.mean, OPTIMUM_U, atol=1e-3)
    # each failed generation doubled the step size around the unchanged mean (0.5)
    spread = [float(np.sqrt(np.mean((U - 0.5) ** 2))) for U in asked[: k + 1]]
    assert all(b > 1.5 * a for a, b in zip(spread, spread[1:], strict=False))


def test_cmaes_same_seed_same_asks_with_failures():
    problem = HoleSphere(dim=3)

    def asks(seed: int) -> np.ndarray:
        s = make_strategy("cmaes", problem, seed=seed, popsize=6, sigma0=0.02)
        return np.vstack(run(s, lambda g, U: problem.evaluate_unit(U), 15))

    a, b = asks(7), asks(7)
    np.testing.assert_array_equal(a, b)
    other = asks(8)
    assert not np.array_equal(a[: len(other)], other[: len(a)])


def test_cmaes_stops_after_max_failed_generations_with_that_reason():
    problem = make_problem("Sphere", dim=3)
    s = make_strategy("cmaes", problem, seed=1, popsize=6, max_failed_generations=3)
    for _ in range(2):
        U = s.ask()
        s.tell(U, failed(U, message="LockupError: the arm folds"))
        assert s.stop() is None
    U = s.ask()
    s.tell(U, failed(U, message="LockupError: the arm folds"))
    reason = s.stop()
    assert reason is not None
    assert "every design failed in 3 consecutive generations" in reason
    assert "max_failed_generations=3" in reason
    assert "LockupError: the arm folds" in reason


def test_a_generation_with_one_success_resets_the_count():
    problem = make_problem("Sphere", dim=3)
    s = make_strategy("cmaes", problem, seed=1, popsize=6, max_failed_generations=3)

    def tell(g: int, U: np.ndarray) -> EvaluationBatch:
        if g == 2:  # one design of the third generation succeeds
            good = problem.evaluate_unit(U[:1])
            return EvaluationBatch.concatenate([good, failed(U[1:])])
        return failed(U)

    asked = run(s, tell, 5)
    assert len(asked) == 5 and s.stop() is None and s.failed_generations == 2


def test_cmaes_restarts_instead_of_stopping_when_restarts_are_left():
    problem = make_problem("Sphere", dim=3)
    s = make_strategy("cmaes", problem, seed=1, popsize=6, max_failed_generations=2, restarts=1)
    asked = run(s, lambda g, U: failed(U), 10)
    assert [len(U) for U in asked] == [6, 6, 12, 12]
    assert s.history[0]["stop"] == {"max_failed_generations": 2}
    assert "after 1 restart(s)" in s.stop()


# ----------------------------------------------------------------------- NSGA-II
def front_gap(problem, U: np.ndarray) -> float:
    """Median distance above ZDT1's Pareto front f2 = 1 - sqrt(f1) (closed form)."""
    F = problem.evaluate_unit(U).objectives
    return float(np.median(F[:, 1] - (1.0 - np.sqrt(F[:, 0]))))


def test_pymoo_nsga2_keeps_its_population_across_failed_generations():
    problem = make_problem("ZDT1", dim=4)
    s = make_strategy("pymoo_nsga2", problem, seed=1, population_size=20)
    run(s, lambda g, U: problem.evaluate_unit(U), 15)
    before = s._algorithm.pop.get("X").copy()
    run(s, lambda g, U: failed(U, 2), 3)
    after = s._algorithm.pop.get("X")
    # the same designs (survival may reorder them), none of them a failed one
    np.testing.assert_array_equal(np.sort(before, axis=0), np.sort(after, axis=0))
    assert np.all(s._algorithm.pop.get("F") < 1e6)
    # and the next generation is bred from them: close to the front, unlike random designs
    assert (
        front_gap(problem, s.ask())
        < 1.0
        < front_gap(problem, np.random.default_rng(0).random((20, 4)))
    )


def test_optuna_nsga2_breeds_from_the_last_successful_generation():
    problem = make_problem("ZDT1", dim=4)
    s = make_strategy("nsga2", problem, seed=1, population_size=20)
    run(s, lambda g, U: problem.evaluate_unit(U), 15)
    key = type(s.study.sampler)._get_generation_key()

    def generation_of_last(n: int) -> set[int]:
        return {t.system_attrs[key] for t in s.study.get_trials()[-n:]}

    (last_good,) = generation_of_last(20)
    run(s, lambda g, U: failed(U, 2), 3)
    U = s.ask()
    # failed trials do not complete a generation: the failed ones and the next ones all
    # belong to the one generation bred from the last successful population
    assert generation_of_last(80) == {last_good + 1}
    assert (
        front_gap(problem, U) < 2.0 < front_gap(problem, np.random.default_rng(0).random((20, 4)))
    )


# ------------------------------------------------------------ random and LHS
@pytest.mark.parametrize("name", ["random", "lhs"])
def test_random_and_lhs_do_not_depend_on_failures(name):
    problem = make_problem("Sphere", dim=3)
    options = {"batch_size": 5} | ({"n_samples": 30} if name == "lhs" else {})
    a = make_strategy(name, problem, seed=2, **options)
    b = make_strategy(name, problem, seed=2, **options)
    asked_a = run(a, lambda g, U: failed(U), 6)
    asked_b = run(b, lambda g, U: problem.evaluate_unit(U), 6)
    assert len(asked_a) == 6
    np.testing.assert_array_equal(np.vstack(asked_a), np.vstack(asked_b))
    assert (a.stop() is None) == (name == "random")  # lhs: its 30 samples are all asked
