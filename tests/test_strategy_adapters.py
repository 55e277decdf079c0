"""The shipped adapters (optuna samplers, nevergrad, differential evolution): each finds a
closed-form optimum within a stated tolerance and budget, asks the same designs for the
same seed and told results, survives failed designs, and (multi-objective ones) beats
random search on ZDT1. A missing optional package skips its tests, and building the
adapter without it is a ValidationError naming the pip extra.

The contract tests of every registered strategy are in ``tests/test_strategies.py``.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from suspenv import make_problem
from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import ValidationError
from suspenv.registry import make_strategy
from suspenv.strategies.extras import FAILED_LOSS, INFEASIBLE_LOSS, told_losses

#: optional package of each adapter (None: core dependencies only)
NEEDS = {
    "optuna_tpe": None,
    "optuna_nsga3": None,
    "optuna_cmaes": "cmaes",
    "optuna_gp": "torch",
    "nevergrad": "nevergrad",
    "de": None,
}


def needs(name: str) -> None:
    """Skip the test when the adapter's optional package is not installed."""
    if NEEDS[name] is not None:
        pytest.importorskip(NEEDS[name])


class ShiftedSphere(Problem):
    """f(x) = sum((x - c)^2) on [0, 1]^d, c = linspace(0.35, 0.65, d): the optimum is c
    (f = 0), in closed form. Optionally designs with ``x0 < fail_below`` fail (ok False,
    NaN), and ``x0_min`` adds the constraint ``x0_min - x0 <= 0``, which moves the optimum
    to ``(max(c0, x0_min), c1, ...)``."""

    name = "ShiftedSphere"

    def __init__(self, dim: int = 3, fail_below: float = 0.0, x0_min: float | None = None):
        self.space = DesignSpace(Parameter(f"x{i}", 0.0, 1.0) for i in range(dim))
        self.objective_names = ("f",)
        self.constraint_names = ("x0_min",) if x0_min is not None else ()
        self.centre = np.linspace(0.35, 0.65, dim)
        self.fail_below, self.x0_min = fail_below, x0_min

    @property
    def optimum(self) -> np.ndarray:
        x = self.centre.copy()
        if self.x0_min is not None:
            x[0] = max(x[0], self.x0_min)
        return x

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        n = len(X)
        f = ((X - self.centre) ** 2).sum(axis=1, keepdims=True)
        g = np.zeros((n, 0)) if self.x0_min is None else self.x0_min - X[:, :1]
        ok = X[:, 0] >= self.fail_below
        f[~ok] = np.nan
        g[~ok] = np.nan
        return EvaluationBatch(f, g, ok, ["" if k else "locks up" for k in ok])


def run(strategy, problem: Problem, budget: int) -> tuple[np.ndarray, EvaluationBatch]:
    """Ask and tell until ``budget`` designs are told (or the strategy stops)."""
    Us, batches = [], []
    while strategy.n_told < budget and strategy.stop() is None:
        U = strategy.ask()
        batch = problem.evaluate_unit(U)
        strategy.tell(U, batch)
        Us.append(U)
        batches.append(batch)
    return np.vstack(Us), EvaluationBatch.concatenate(batches)


def best_feasible(U: np.ndarray, batch: EvaluationBatch) -> np.ndarray:
    f = np.where(batch.feasible, batch.objectives[:, 0], np.inf)
    return U[int(np.argmin(f))]


# name, options, budget (evaluations), tolerance on max |x - x*| of the best design told
SPHERE = [
    ("optuna_tpe", {"batch_size": 4}, 200, 0.03),
    ("optuna_cmaes", {}, 280, 1e-3),
    ("optuna_nsga3", {"population_size": 20}, 400, 0.06),
    ("optuna_gp", {"batch_size": 2}, 40, 0.05),
    ("nevergrad", {"batch_size": 8}, 600, 0.02),
    ("nevergrad", {"optimizer": "CMA", "batch_size": 8}, 400, 1e-3),
    ("de", {}, 45 * 40, 1e-3),
]


@pytest.mark.parametrize(("name", "options", "budget", "tol"), SPHERE)
def test_adapter_finds_shifted_sphere_optimum(name, options, budget, tol):
    needs(name)
    problem = ShiftedSphere(dim=3)
    s = make_strategy(name, problem, seed=1, **options)
    U, batch = run(s, problem, budget)
    assert batch.ok.all()
    np.testing.assert_allclose(best_feasible(U, batch), problem.optimum, atol=tol)


# the constraint x0 >= 0.6 moves the optimum from c0 = 0.35 to x0 = 0.6
CONSTRAINED = [
    ("optuna_tpe", {"batch_size": 4}, 200, 0.06),
    ("optuna_cmaes", {}, 350, 0.02),
    ("nevergrad", {"batch_size": 8}, 800, 0.02),
    ("de", {}, 45 * 50, 0.02),
]


@pytest.mark.parametrize(("name", "options", "budget", "tol"), CONSTRAINED)
def test_adapter_respects_constraints(name, options, budget, tol):
    needs(name)
    problem = ShiftedSphere(dim=3, x0_min=0.6)
    s = make_strategy(name, problem, seed=2, **options)
    U, batch = run(s, problem, budget)
    late = batch.feasible[len(U) // 2 :]
    assert late.mean() > 0.5  # the search has moved into the feasible region
    np.testing.assert_allclose(best_feasible(U, batch), problem.optimum, atol=tol)


REPLAY = [(name, {"population_size": 10} if name == "optuna_nsga3" else {}) for name in NEEDS]
REPLAY += [("nevergrad", {"optimizer": "CMA"}), ("nevergrad", {"optimizer": "DE", "batch_size": 4})]


@pytest.mark.parametrize(("name", "options"), REPLAY)
def test_same_seed_and_results_same_designs_and_global_rng_untouched(name, options):
    # resume replays a run: a strategy rebuilt with the same seed and options and told
    # the same results must ask the same designs; and no strategy draws from (or moves)
    # numpy's global generator
    needs(name)
    problem = ShiftedSphere(dim=3, fail_below=0.2, x0_min=0.3)
    runs = []
    for glob in (5, 6):
        np.random.seed(glob)
        before = np.random.rand()
        np.random.seed(glob)
        s = make_strategy(name, problem, seed=7, **options)
        runs.append(run(s, problem, 40)[0])
        assert np.random.rand() == before, f"{name} moved numpy's global generator"
    np.testing.assert_array_equal(runs[0], runs[1])
    other = make_strategy(name, problem, seed=8, **options).ask()
    assert not np.array_equal(other, runs[0][: len(other)])


@pytest.mark.parametrize("name", list(NEEDS))
def test_resumed_run_equals_an_uninterrupted_one(tmp_path, name):
    # the run loop resumes a run directory by replaying the strategy against its archive
    needs(name)
    from suspenv.runs.archive import RunArchive
    from suspenv.runs.loop import optimize

    problem = ShiftedSphere(dim=2, fail_below=0.2)
    options = {"population_size": 8} if name == "optuna_nsga3" else {}
    if name == "de":
        options = {"popsize": 4}
    options |= {"batch_size": 4} if name in ("optuna_tpe", "optuna_gp", "nevergrad") else {}

    def strategy():
        return make_strategy(name, problem, seed=4, **options)

    optimize(problem, strategy(), budget=16, run_dir=tmp_path / "run")
    r = optimize(problem, strategy(), budget=40, run_dir=tmp_path / "run")
    assert r.n_resumed >= 8
    optimize(problem, strategy(), budget=40, run_dir=tmp_path / "ref")
    with RunArchive(tmp_path / "run") as a, RunArchive(tmp_path / "ref") as b:
        np.testing.assert_array_equal(a.arrays()["x"], b.arrays()["x"])


FAILING = [
    ("optuna_tpe", {"batch_size": 4}, 200, 0.05),
    ("optuna_cmaes", {}, 280, 1e-3),
    ("nevergrad", {"batch_size": 8}, 600, 0.03),
    ("de", {}, 45 * 40, 1e-3),
]


@pytest.mark.parametrize(("name", "options", "budget", "tol"), FAILING)
def test_failed_region_is_survived_and_avoided(name, options, budget, tol):
    # designs with x0 < 0.25 fail (ok False, NaN objectives): the strategy keeps going,
    # learns to avoid the region and still finds the optimum (x0* = 0.35)
    needs(name)
    problem = ShiftedSphere(dim=3, fail_below=0.25)
    s = make_strategy(name, problem, seed=3, **options)
    U, batch = run(s, problem, budget)
    assert (~batch.ok).any()  # the region was visited ...
    assert (~batch.ok[len(U) // 2 :]).mean() < (~batch.ok[: len(U) // 4]).mean() + 0.05
    np.testing.assert_allclose(best_feasible(U, batch), problem.optimum, atol=tol)


@pytest.mark.parametrize("name", list(NEEDS))
def test_a_batch_in_which_every_design_fails(name):
    needs(name)
    problem = ShiftedSphere(dim=2)
    s = make_strategy(name, problem, seed=0)
    for _ in range(3):
        U = s.ask()
        s.tell(U, EvaluationBatch.failed(len(U), 1, 0, "solver diverged"))
    U = s.ask()
    assert U.shape[1] == 2 and np.all((U >= 0) & (U <= 1))


def test_optuna_failed_designs_are_failed_trials():
    problem = ShiftedSphere(dim=2, fail_below=0.5)
    s = make_strategy("optuna_tpe", problem, seed=0, batch_size=5)
    U, batch = run(s, problem, 20)
    states = [t.state.name for t in s.study.get_trials()]
    assert states.count("FAIL") == int((~batch.ok).sum()) > 0
    assert states.count("COMPLETE") == int(batch.ok.sum())


@pytest.mark.parametrize(
    ("name", "options"),
    [
        ("nsga2", {"population_size": 4}),
        ("optuna_tpe", {"batch_size": 4}),
        ("optuna_nsga3", {"population_size": 4}),
    ],
)
def test_optuna_unknown_constraint_is_told_as_a_large_violation(name, options):
    """A successful design whose constraint is NaN (optuna refuses NaN) completes with the
    violation 1e300, so every sampler ranks it after the feasible designs."""
    from suspenv.strategies.nsga2 import CONSTRAINTS_KEY, PER_TRIAL_CONSTRAINTS

    problem = ShiftedSphere(dim=2, x0_min=0.5)
    s = make_strategy(name, problem, seed=0, **options)
    U = s.ask()
    batch = problem.evaluate_unit(U)
    batch.constraints[0] = np.nan
    s.tell(U, batch)
    trial = s.study.get_trials()[0]
    told = (
        trial.system_attrs["constraints:g0"]
        if PER_TRIAL_CONSTRAINTS
        else trial.user_attrs[CONSTRAINTS_KEY][0]
    )
    assert trial.state.name == "COMPLETE" and told == 1e300


# ------------------------------------------------------------ multi-objective
def hypervolume_2d(F: np.ndarray, ref: np.ndarray) -> float:
    """Hypervolume (minimisation) of the points F (n, 2) below the reference point."""
    F = F[np.isfinite(F).all(axis=1) & (ref - F > 0).all(axis=1)]
    F = F[np.argsort(F[:, 0], kind="stable")]
    hv, top = 0.0, ref[1]
    for f1, f2 in F:
        if f2 < top:
            hv += (ref[0] - f1) * (top - f2)
            top = f2
    return hv


def test_hypervolume_helper_against_closed_form():
    ref = np.array([1.1, 1.1])
    # two points: rectangles (1.1-0.2)(1.1-0.5) + (1.1-0.6)(0.5-0.1)
    F = np.array([[0.2, 0.5], [0.6, 0.1], [0.7, 0.6], [2.0, 0.0]])
    assert hypervolume_2d(F, ref) == pytest.approx(0.9 * 0.6 + 0.5 * 0.4)


# reference point (1.1, 1.1): the ZDT1 front f2 = 1 - sqrt(f1), f1 in [0, 1], lies below it
# and its hypervolume is 0.1 + 2/3 + 0.11 = 0.877 (closed form)
ZDT1_REF = np.array([1.1, 1.1])
MULTI = [
    ("optuna_tpe", {"batch_size": 10}, 300),
    ("optuna_nsga3", {"population_size": 20}, 600),
    ("optuna_gp", {"batch_size": 5}, 60),
    ("nevergrad", {"batch_size": 10}, 600),
    ("nevergrad", {"optimizer": "DE", "batch_size": 10}, 600),
]


class FragileZDT1(type(make_problem("ZDT1"))):
    """ZDT1 whose designs with x3 > 0.8 fail (the Pareto front, x1 = x2 = x3 = 0, does
    not)."""

    def _evaluate(self, X):
        batch = super()._evaluate(X)
        bad = X[:, -1] > 0.8
        batch.objectives[bad] = np.nan
        batch.ok[bad] = False
        return batch


@pytest.mark.parametrize(("name", "options", "budget"), MULTI)
def test_multi_objective_front_beats_random_search_on_zdt1(name, options, budget):
    # equal budgets, failed designs included (a fifth of random search's designs fail)
    needs(name)
    problem = FragileZDT1(dim=4)
    _, batch = run(make_strategy(name, problem, seed=0, **options), problem, budget)
    _, rand = run(make_strategy("random", problem, seed=0, batch_size=10), problem, budget)
    hv = hypervolume_2d(batch.objectives, ZDT1_REF)
    hv_random = hypervolume_2d(rand.objectives, ZDT1_REF)
    assert len(batch) == len(rand) == budget and (~rand.ok).any()
    assert hv > 1.5 * hv_random and hv < 0.8767, (hv, hv_random)


def test_nevergrad_reference_point_is_told_before_the_first_design():
    pytest.importorskip("nevergrad")
    problem = make_problem("ZDT1", dim=3)
    s = make_strategy(
        "nevergrad", problem, seed=0, optimizer="CMA", batch_size=5, reference_point=[1.1, 10]
    )
    run(s, problem, 10)
    bound = s.ng_optimizer._hypervolume_pareto._upper_bounds  # nevergrad's reference point
    np.testing.assert_array_equal(bound, [1.1, 10.0])


# ----------------------------------------------------------- batches, options
def test_batch_sizes():
    problem = ShiftedSphere(dim=4)
    assert len(make_strategy("optuna_tpe", problem).ask()) == 1
    assert len(make_strategy("optuna_tpe", problem, batch_size=6).ask()) == 6
    assert len(make_strategy("optuna_nsga3", problem, population_size=12).ask()) == 12
    assert len(make_strategy("de", problem).ask()) == 60  # scipy's popsize 15 * d
    assert len(make_strategy("de", ShiftedSphere(dim=1), popsize=2).ask()) == 5  # at least 5


def test_optuna_cmaes_asks_one_generation():
    pytest.importorskip("cmaes")
    problem = ShiftedSphere(dim=4)
    s = make_strategy("optuna_cmaes", problem, seed=0)
    assert len(s.ask()) == 4 + int(3 * np.log(4)) == s.options()["popsize"]


def test_nevergrad_budget_cuts_the_last_batch_and_stops():
    pytest.importorskip("nevergrad")
    problem = ShiftedSphere(dim=2)
    s = make_strategy("nevergrad", problem, seed=0, batch_size=8, budget=20)
    sizes = []
    while s.stop() is None:
        U = s.ask()
        sizes.append(len(U))
        s.tell(U, problem.evaluate_unit(U))
    assert sizes == [8, 8, 4] and s.stop() == "nevergrad: budget=20 designs told"


def test_de_agrees_with_scipy_differential_evolution():
    # the same algorithm and defaults (best1bin, dithering (0.5, 1), CR 0.7, popsize 15 d,
    # Latin hypercube, deferred updating) from different random streams: the generations
    # needed to reach f < 1e-6 on the shifted sphere agree in median within 30 %
    from scipy.optimize import differential_evolution

    problem = ShiftedSphere(dim=3)

    def f(X):
        return ((np.atleast_2d(X) - problem.centre) ** 2).sum(axis=1)

    def scipy_generations(seed):
        values = []
        differential_evolution(
            lambda XT: f(XT.T),
            [(0.0, 1.0)] * 3,
            vectorized=True,
            updating="deferred",
            polish=False,
            tol=0.0,
            maxiter=60,
            rng=seed,
            callback=lambda intermediate_result: values.append(intermediate_result.fun),
        )
        return int(np.argmax(np.array(values) < 1e-6)) + 1

    def our_generations(seed):
        s = make_strategy("de", problem, seed=seed, tol=0.0)
        run(s, problem, 45)  # the initial population
        while s.best_value >= 1e-6 and s.generation < 200:
            run(s, problem, s.n_told + 45)
        return s.generation

    ours = np.median([our_generations(seed) for seed in range(5)])
    theirs = np.median([scipy_generations(seed) for seed in range(5)])
    assert abs(ours / theirs - 1) < 0.3, (ours, theirs)


def test_de_stops_when_converged_by_scipys_rule():
    problem = ShiftedSphere(dim=2)
    s = make_strategy("de", problem, seed=0, tol=0.01)
    run(s, problem, 10**6)
    reason = s.stop()
    assert reason.startswith("de: converged after")
    E = s.population_energies
    assert np.std(E) <= 0.01 * abs(np.mean(E))
    s = make_strategy("de", problem, seed=0, maxiter=3)
    run(s, problem, 10**6)
    assert s.stop() == "de: maxiter=3 generations done" and s.n_told == 4 * 30


def test_told_losses_order_feasible_infeasible_failed():
    batch = EvaluationBatch(
        np.array([[3.0], [-1.0], [0.5], [0.5], [np.nan]]),
        np.array([[0.0], [-2.0], [0.1], [5.0], [np.nan]]),
        np.array([True, True, True, True, False]),
        [""] * 4 + ["x"],
    )
    loss = told_losses(batch)[:, 0]
    np.testing.assert_array_equal(loss[:2], [3.0, -1.0])
    assert INFEASIBLE_LOSS <= loss[2] < loss[3] < 2 * INFEASIBLE_LOSS < loss[4] == FAILED_LOSS


@pytest.mark.parametrize(
    ("name", "options", "fragments"),
    [
        ("nevergrad", {"optimizer": "TwoPointDE"}, ("did you mean 'TwoPointsDE'",)),
        ("nevergrad", {"optimizer": "NGOpt"}, ("`budget`", "budget=None")),
        ("nevergrad", {"optimizer": "Cobyla", "batch_size": 4}, ("`batch_size == 1`",)),
        ("nevergrad", {"reference_point": [1.0]}, ("several objectives",)),
        ("nevergrad", {"batch_size": 0}, ("`batch_size >= 1` must hold",)),
        ("optuna_tpe", {"multivariate": 1}, ("`multivariate` must be True, False or None",)),
        ("optuna_tpe", {"n_startup_trials": -1}, ("`n_startup_trials >= 0`",)),
        ("optuna_cmaes", {"popsize": 1}, ("`popsize >= 2` must hold",)),
        ("optuna_nsga3", {"crossover_prob": 2}, ("`0 <= crossover_prob <= 1`",)),
        ("de", {"mutation": [1.0, 0.5]}, ("`mutation[0] <= mutation[1]`",)),
        ("de", {"mutation": 2.0}, ("`0 <= mutation < 2`",)),
        ("de", {"strategy": "best1exp"}, ("`strategy` must be one of",)),
        ("de", {"weights": [1.0, 2.0]}, ("`len(weights) == 1`",)),
    ],
)
def test_options_are_checked(name, options, fragments):
    needs(name)
    with pytest.raises(ValidationError) as err:
        make_strategy(name, ShiftedSphere(dim=2), **options)
    for fragment in fragments:
        assert fragment in str(err.value), str(err.value)


@pytest.mark.parametrize(
    ("name", "module", "extra"),
    [
        ("nevergrad", "nevergrad", "nevergrad"),
        ("optuna_cmaes", "cmaes", "optuna-cmaes"),
        ("optuna_gp", "torch", "optuna-gp"),
    ],
)
def test_missing_optional_package_names_the_extra(monkeypatch, name, module, extra):
    monkeypatch.setitem(sys.modules, module, None)  # `import module` raises ImportError
    with pytest.raises(ValidationError) as err:
        make_strategy(name, ShiftedSphere(dim=2))
    assert f"needs the optional package {module!r}" in str(err.value)
    assert f"pip install 'suspenv[{extra}]'" in str(err.value)
