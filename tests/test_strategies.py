"""Contract tests for every registered strategy and every plug-in of ``strategies/``, plus
each adapter's own promises."""

from pathlib import Path

import numpy as np
import pytest

from suspenv import make_problem
from suspenv.core import EvaluationBatch
from suspenv.core.errors import ValidationError
from suspenv.core.scalarize import penalized_fitness, rank_sum, weighted_sum
from suspenv.registry import list_strategies, make_strategy, register_strategy, strategy_class
from suspenv.strategies.base import Strategy
from suspenv.strategies.extras import MissingExtraError

#: the plug-ins shipped in the top-level ``strategies/`` folder, named by file
PLUGINS = [
    f"{f}:{cls}"
    for f, cls in (
        (Path(__file__).parents[1] / "strategies" / "centre.py", "Centre"),
        (Path(__file__).parents[1] / "strategies" / "pymoo_pso.py", "PymooPSO"),
    )
]


def make_or_skip(name, problem, **options):
    """``make_strategy``, or skip when the strategy's optional package is not installed."""
    try:
        return make_strategy(name, problem, **options)
    except MissingExtraError as exc:
        pytest.skip(str(exc))


@pytest.mark.parametrize("name", list_strategies() + PLUGINS)
def test_contract_ask_tell_in_unit_cube(name):
    problem = make_problem("ZDT1", dim=4)
    s = make_or_skip(name, problem, seed=3)
    for _ in range(3):
        if s.stop():
            break
        U = s.ask()
        assert U.ndim == 2 and U.shape[1] == 4 and len(U) >= 1
        assert np.all((U >= 0) & (U <= 1))
        with pytest.raises(RuntimeError, match="before tell"):
            s.ask()
        s.tell(U, problem.evaluate_unit(U))


@pytest.mark.parametrize("name", list_strategies() + PLUGINS)
def test_contract_same_seed_same_designs(name):
    problem = make_problem("ZDT1", dim=3)
    runs = []
    for _ in range(2):
        s = make_or_skip(name, problem, seed=11)
        seq = []
        for _ in range(3):
            U = s.ask()
            s.tell(U, problem.evaluate_unit(U))
            seq.append(U)
        runs.append(np.vstack(seq))
    np.testing.assert_array_equal(runs[0], runs[1])
    other = make_or_skip(name, problem, seed=12).ask()
    assert not np.array_equal(other, runs[0][: len(other)])


@pytest.mark.parametrize("name", list_strategies() + PLUGINS)
def test_contract_partial_tell_rejected(name):
    problem = make_problem("Sphere", dim=3)
    s = make_or_skip(name, problem, seed=0)
    U = s.ask()
    if len(U) < 2:
        pytest.skip("batch of one")
    with pytest.raises(ValidationError, match="whole asked population"):
        s.tell(U[:-1], problem.evaluate_unit(U[:-1]))


def test_cmaes_converges_on_sphere_and_seed_never_clock():
    problem = make_problem("Sphere", dim=5)
    s = make_strategy("cmaes", problem, seed=1, popsize=10)
    for _ in range(80):
        U = s.ask()
        s.tell(U, problem.evaluate_unit(U))
    # the optimum of Sphere is x = 0.3 -> unit 0.65 (closed form)
    np.testing.assert_allclose(s.mean, 0.65, atol=1e-3)


def test_cmaes_ipop_restart_grows_population():
    problem = make_problem("Sphere", dim=2)
    s = make_strategy("cmaes", problem, seed=2, popsize=6, restarts=1, tolfun=1e-3, tolx=1e-3)
    sizes = set()
    for _ in range(200):
        if s.stop():
            break
        U = s.ask()
        sizes.add(len(U))
        s.tell(U, problem.evaluate_unit(U))
    assert sizes == {6, 12}
    assert s.restart_count == 1
    assert s.stop() and "1 restart" in s.stop()


def test_cmaes_does_not_touch_global_numpy_rng():
    np.random.seed(5)
    a = np.random.rand()
    np.random.seed(5)
    s = make_strategy("cmaes", make_problem("Sphere", dim=3), seed=1)
    s.ask()
    assert np.random.rand() == a


@pytest.mark.parametrize("name", ["nsga2", "pymoo_nsga2"])
def test_nsga2_one_generation_per_ask_and_constraints(name):
    zdt1 = type(make_problem("ZDT1"))

    class Constrained(zdt1):
        def __init__(self, active=True):
            super().__init__(dim=3)
            self.constraint_names = ("x0_min",) if active else ()
            self.active = active

        def _evaluate(self, X):
            b = super()._evaluate(X)
            if self.active:
                b.constraints = 0.7 - X[:, :1]  # feasible when x0 >= 0.7
            return b

    def late_feasible_share(problem):
        s = make_strategy(name, problem, seed=4, population_size=20)
        shares = []
        for _ in range(10):
            U = s.ask()
            assert len(U) == 20
            s.tell(U, problem.evaluate_unit(U))
            shares.append(np.mean(problem.space.to_physical(U)[:, 0] >= 0.7))
        if name == "nsga2":
            assert len(s.study.get_trials()) == 200
        return np.mean(shares[5:])

    # unconstrained ZDT1 spreads x0 over [0, 1]: only ~30 % reach x0 >= 0.7;
    # with the constraint told through optuna, the late generations are mostly feasible
    assert late_feasible_share(Constrained(active=False)) < 0.5
    assert late_feasible_share(Constrained(active=True)) > 0.65


def test_lhs_strata_and_stop():
    problem = make_problem("Sphere", dim=4)
    s = make_strategy("lhs", problem, seed=0, n_samples=30, batch_size=8)
    got = []
    while not s.stop():
        U = s.ask()
        got.append(U)
        s.tell(U, problem.evaluate_unit(U))
    U = np.vstack(got)
    assert U.shape == (30, 4) and [len(g) for g in got] == [8, 8, 8, 6]
    # Latin property: exactly one point per 1/30 stratum in every dimension
    for j in range(4):
        assert sorted(np.floor(U[:, j] * 30).astype(int)) == list(range(30))


def test_rank_sum_matches_hand_calculation():
    # Tey et al. 2014 rank-sum, computed by hand for a 3x2 batch:
    # column 0: (1, 3, 5) -> (0, 5, 10); column 1: (10, 10, 20) -> (0, 0, 10)
    F = np.array([[1.0, 10.0], [3.0, 10.0], [5.0, 20.0]])
    np.testing.assert_allclose(rank_sum(F), [0.0, 5.0, 20.0])
    np.testing.assert_allclose(rank_sum(F, valid=np.array([True, True, False]))[:2], [0, 10])
    assert np.isnan(rank_sum(F, valid=np.array([True, True, False]))[2])
    np.testing.assert_allclose(weighted_sum(F, [1.0, 0.5]), [6.0, 8.0, 15.0])


def test_penalized_fitness_orders_feasible_infeasible_failed():
    f = np.array([3.0, 1.0, 0.5, np.nan, 2.0])
    ok = np.array([True, True, True, False, True])
    v = np.array([0.0, 0.0, 2.0, np.nan, 1.0])
    p = penalized_fitness(f, ok, v)
    order = list(np.argsort(p))
    assert order == [1, 0, 4, 2, 3]
    assert np.all(np.isfinite(p))


def test_user_strategy_plugs_in_through_registry():
    class Centre(Strategy):
        name = "centre"

        def _ask(self):
            return np.full((2, self.dim), 0.5)

        def _tell(self, U, batch):
            self.last = batch.objectives

    register_strategy("centre_test", Centre, overwrite=True)
    problem = make_problem("Sphere", dim=2)
    from suspenv.runs.loop import optimize

    r = optimize(problem, make_strategy("centre_test", problem, seed=0), budget=6)
    assert r.n_evaluations == 6 and strategy_class("centre_test") is Centre


def test_unknown_strategy_and_option_suggest_names():
    problem = make_problem("Sphere", dim=2)
    with pytest.raises(ValidationError, match="did you mean 'cmaes'"):
        make_strategy("cmaess", problem)
    with pytest.raises(ValidationError, match="did you mean 'popsize'"):
        make_strategy("cmaes", problem, popsiz=4)
    with pytest.raises(ValidationError, match=r"`0 < sigma0 <= 1` must hold, but got sigma0=2"):
        make_strategy("cmaes", problem, sigma0=2)


def test_failed_rows_do_not_break_cmaes():
    problem = make_problem("Sphere", dim=3)
    s = make_strategy("cmaes", problem, seed=0, popsize=6)
    U = s.ask()
    b = problem.evaluate_unit(U)
    bad = EvaluationBatch.concatenate([b.take([0, 1, 2]), EvaluationBatch.failed(3, 1, 0, "x")])
    s.tell(U, bad)
    assert s.ask().shape == (6, 3)


def test_pymoo_nsga2_approaches_zdt1_front_and_survives_failures():
    problem = make_problem("ZDT1", dim=4)
    s = make_strategy("pymoo_nsga2", problem, seed=1, population_size=40)
    for g in range(40):
        U = s.ask()
        batch = problem.evaluate_unit(U)
        if g % 5 == 0:  # every fifth generation loses a few evaluations
            batch = EvaluationBatch.concatenate(
                [batch.take(np.arange(35)), EvaluationBatch.failed(5, 2, 0, "lost")]
            )
        s.tell(U, batch)
    F = problem.evaluate_unit(U).objectives
    # ZDT1 Pareto front (closed form): f2 = 1 - sqrt(f1); the population lies close to it
    gap = F[:, 1] - (1 - np.sqrt(F[:, 0]))
    assert np.median(gap) < 0.05


def test_plugin_by_file_and_module_and_refusals(tmp_path, monkeypatch):
    problem = make_problem("Sphere", dim=2)
    cls = strategy_class(PLUGINS[0])
    assert cls.__name__ == "Centre" and strategy_class(PLUGINS[0]) is cls  # imported once
    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "my_plugins.py").write_text(
        "from suspenv.strategies.random_search import RandomSearch as Mine\nNot = int\n"
    )
    assert strategy_class("my_plugins:Mine").name == "random"
    with pytest.raises(ValidationError, match="must be a class with the methods ask, tell, stop"):
        make_strategy("my_plugins:Not", problem)
    with pytest.raises(ValidationError, match="no file"):
        make_strategy(str(tmp_path / "absent.py") + ":X", problem)
    with pytest.raises(ValidationError, match="cannot import 'no_such_module'"):
        make_strategy("no_such_module:X", problem)


def test_installed_package_registers_through_the_entry_point_group(tmp_path, monkeypatch):
    # an installed distribution as importlib.metadata finds it: a .dist-info folder on
    # sys.path with entry_points.txt (what `pip install` of a package declaring
    # [project.entry-points."suspenv.strategies"] writes)
    (tmp_path / "ep_pkg.py").write_text(
        "from suspenv.strategies.random_search import RandomSearch\n"
        "class EpRandom(RandomSearch):\n    name = 'ep_random'\n"
    )
    info = tmp_path / "ep_pkg-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: ep-pkg\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[suspenv.strategies]\nep_random = ep_pkg:EpRandom\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    from suspenv import registry

    monkeypatch.setattr(registry, "_STRATEGIES", dict(registry._STRATEGIES))
    assert "ep_random" in list_strategies()
    s = make_strategy("ep_random", make_problem("Sphere", dim=3), seed=1)
    assert type(s).__name__ == "EpRandom" and s.ask().shape[1] == 3
