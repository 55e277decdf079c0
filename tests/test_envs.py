"""The Gymnasium face: every registered problem passes ``check_env``; env contracts."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.envs import ProblemEnv, ProblemVectorEnv, env_id, make_env, make_vector_env
from suspenv.envs.adapter import FAIL_VALUE, MixedUnitsWarning
from suspenv.registry import list_problems, make_problem


# ------------------------------------------------------------------ helpers
class Flaky(Problem):
    """f = (x0, x1^2); the physics "fails" (EvaluationError) where x0 > 0.5."""

    name = "Flaky"

    def __init__(self):
        self.space = DesignSpace([Parameter("x0", 0.0, 1.0), Parameter("x1", -1.0, 1.0)])
        self.objective_names = ("f1", "f2")
        self.constraint_names = ("g",)

    def _evaluate(self, X):
        if (X[:, 0] > 0.5).any():
            raise EvaluationError("linkage locks up at x0 > 0.5")
        n = len(X)
        F = np.c_[X[:, 0], X[:, 1] ** 2]
        return EvaluationBatch(F, X[:, 1:2] - 0.5, np.ones(n, bool), [""] * n)


class Painted(Problem):
    """One parameter; ``render_rgb`` paints a bar whose width is the design value."""

    name = "Painted"

    def __init__(self):
        self.space = DesignSpace([Parameter("w", 0.0, 1.0)])
        self.objective_names = ("f",)

    def _evaluate(self, X):
        n = len(X)
        return EvaluationBatch(X.copy(), np.zeros((n, 0)), np.ones(n, bool), [""] * n)

    def render_rgb(self, x):
        img = np.zeros((8, 20, 3), dtype=np.uint8)
        img[:, : int(round(20 * x[0])), 0] = 255
        return img


class Counting(Problem):
    """Wraps a problem and counts ``evaluate`` calls and rows."""

    def __init__(self, inner: Problem):
        self.inner = inner
        self.space = inner.space
        self.objective_names = inner.objective_names
        self.constraint_names = inner.constraint_names
        self.calls: list[int] = []

    def evaluate(self, X):
        self.calls.append(len(np.atleast_2d(X)))
        return self.inner.evaluate(X)

    def _evaluate(self, X):  # pragma: no cover - evaluate is overridden
        raise AssertionError


def make_or_skip(name: str, **kwargs) -> gym.Env:
    """gym.make for a registered problem; skip while its module is not written yet."""
    try:
        return gym.make(env_id(name), **kwargs)
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.startswith("suspenv"):
            pytest.skip(f"problem {name!r}: module {exc.name!r} does not exist yet")
        raise


def gym_warnings(record) -> list[str]:
    return [str(w.message) for w in record if "WARN" in str(w.message)]


# ----------------------------------------------------------- every problem
@pytest.mark.parametrize("name", list_problems())
def test_check_env_passes_for_every_registered_problem(name):
    env = make_or_skip(name, budget=5)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    assert gym_warnings(record) == []
    problem = env.unwrapped.problem
    assert env.unwrapped.action_space.shape == (problem.space.dim,)
    assert env.unwrapped.action_space.dtype == np.float64
    assert env.unwrapped.observation_space.shape == (problem.n_objectives,)
    env.close()


@pytest.mark.parametrize("name", list_problems())
def test_every_problem_has_a_vector_env(name):
    try:
        vec = make_vector_env(name, num_envs=3, budget=2)
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.startswith("suspenv"):
            pytest.skip(f"problem {name!r}: module {exc.name!r} does not exist yet")
        raise
    assert isinstance(vec.unwrapped, ProblemVectorEnv)
    obs, info = vec.reset(seed=0)
    assert obs in vec.observation_space
    obs, reward, term, trunc, info = vec.step(vec.action_space.sample())
    assert obs in vec.observation_space and reward.shape == (3,)
    assert not term.any() and not trunc.any()
    vec.close()


def test_registration_is_lazy_and_covers_every_problem():
    code = (
        "import sys, gymnasium as gym, suspenv.envs\n"
        "from suspenv.registry import list_problems\n"
        "assert not [m for m in sys.modules if m.startswith('suspenv.problems.')], sys.modules\n"
        "missing = [n for n in list_problems() if f'suspenv/{n}-v0' not in gym.registry]\n"
        "assert not missing, missing\n"
        "spec = gym.spec('suspenv/CarSideImpact-v0')\n"
        "assert spec.kwargs == {'problem': 'CarSideImpact'}, spec.kwargs\n"
        "assert spec.vector_entry_point is not None\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_make_env_accepts_names_and_ids_and_suggests():
    assert make_env("ZDT1").unwrapped.problem.name == "ZDT1"
    assert make_env("suspenv/ZDT1-v0", budget=3).unwrapped.budget == 3
    with pytest.raises(ValidationError, match="did you mean 'CarSideImpact'"):
        make_env("CarSideImpct")


def test_problem_options_reach_the_problem():
    env = make_env("CarSideImpact", problem_options={"variant": "RE41"})
    assert env.observation_space.shape == (4,)
    with pytest.raises(ValidationError, match="problem_options"):
        ProblemEnv(make_problem("Sphere"), problem_options={"dim": 3})


# -------------------------------------------------------------- contracts
def test_reset_evaluates_the_reference_design():
    env = ProblemEnv("CarSideImpact")
    obs, info = env.reset(seed=3)
    problem = make_problem("CarSideImpact")
    ref = problem.reference_design()
    batch = problem.evaluate(ref)
    np.testing.assert_array_equal(obs, batch.objectives[0])
    assert info["parameters"] == problem.space.as_dict(ref)
    assert info["evaluations"] == 0 and info["ok"] is True


def test_action_maps_through_the_unit_cube_to_physical_values():
    env = ProblemEnv("CarSideImpact")
    env.reset(seed=0)
    space = env.problem.space
    # a = -1 -> lower bounds, a = +1 -> upper bounds, a = 0 -> centre (linear parameters)
    for a, want in (
        (-1.0, space.lower),
        (1.0, space.upper),
        (0.0, (space.lower + space.upper) / 2),
    ):
        _, _, _, _, info = env.step(np.full(space.dim, a))
        np.testing.assert_allclose(list(info["parameters"].values()), want, rtol=1e-12)
    x = space.lower + 0.3 * (space.upper - space.lower)
    _, _, _, _, info = env.step(env.design_to_action(x))
    np.testing.assert_allclose(list(info["parameters"].values()), x, rtol=1e-12)


def test_truncation_at_budget_and_terminated_never():
    env = ProblemEnv("Sphere", problem_options={"dim": 2}, budget=3)
    env.reset(seed=0)
    flags = [env.step(np.zeros(2))[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]
    with pytest.raises(RuntimeError, match="budget=3"):
        env.step(np.zeros(2))
    env.reset()
    assert env.step(np.zeros(2))[3] is False


@pytest.mark.parametrize(
    ("budget", "message"),
    [
        (0, "ProblemEnv: `budget >= 1` must hold, but got budget=0"),
        (-1, "ProblemEnv: `budget >= 1` must hold, but got budget=-1"),
        (2.5, "`budget` must be an integer with `budget >= 1`, but got budget=2.5"),
        (True, "`budget` must be an integer with `budget >= 1`, but got budget=True (bool)"),
        ("10", "`budget` must be an integer with `budget >= 1`, but got budget='10' (str)"),
    ],
)
def test_bad_budget_is_rejected(budget, message):
    with pytest.raises(ValidationError) as err:
        ProblemEnv("Sphere", budget=budget)
    assert message in str(err.value)


def test_reward_is_minus_the_objective_for_one_objective():
    env = ProblemEnv("Sphere", problem_options={"dim": 3})
    env.reset(seed=0)
    # Sphere: f = sum((x - 0.3)^2) on [-1, 1]^3, where the action equals x
    a = np.array([0.5, -0.2, 0.9])
    obs, reward, *_ = env.step(a)
    f = (0.2**2) + (0.5**2) + (0.6**2)  # hand calculation: 0.04 + 0.25 + 0.36
    assert obs[0] == pytest.approx(0.65) and reward == pytest.approx(-f)
    _, best, *_ = env.step(np.full(3, 0.3))
    assert best == pytest.approx(0.0, abs=1e-15) and best > reward


def test_reward_weights_and_constraint_penalty():
    # CarSideImpact at x = 1 (hand calculation in test_carside): F = (29.05001, 4.03,
    # 12.175625); relative violations 0.000296875 (rib lower) + 0.0075 (pubic force)
    x = np.ones(7)
    # the weights in the objectives' own units: asked for (the default normalises them)
    with pytest.warns(MixedUnitsWarning, match=r"\(kN, kg, m/s\)"):
        env = ProblemEnv("CarSideImpact", weights=[1.0, 2.0, 0.5], penalty=10.0, reward="sum")
    env.reset(seed=0)
    _, reward, _, _, info = env.step(env.design_to_action(x))
    s = 29.05001 + 2 * 4.03 + 0.5 * 12.175625
    v = 0.000296875 + 0.0075
    assert info["violation"] == pytest.approx(v, abs=1e-12)
    assert info["scalarized"] == pytest.approx(s, rel=1e-12)
    assert reward == pytest.approx(-(s + 10.0 * v), rel=1e-12)
    with pytest.raises(ValidationError, match=r"env: `len\(weights\) == 3` must hold"):
        ProblemEnv("CarSideImpact", weights=[1.0, 2.0])


def test_failed_evaluation_is_a_documented_finite_observation():
    env = ProblemEnv(Flaky(), budget=4)
    env.reset(seed=0)
    obs, reward, term, trunc, info = env.step(np.array([0.8, 0.0]))  # x0 = 0.9 > 0.5
    assert info["ok"] is False and "locks up" in info["message"]
    np.testing.assert_array_equal(obs, [FAIL_VALUE, FAIL_VALUE])
    # the reward: the lowest seen (the reference design x = (0.5, 0): f = (0.5, 0),
    # g = -0.5 feasible, reward -0.5) minus 0.1 * 0.5 + 1, not -1e10
    assert obs in env.observation_space and reward == pytest.approx(-0.5 - 1.05)
    np.testing.assert_array_equal(info["constraints"], [FAIL_VALUE])
    obs, reward, _, _, info = env.step(np.array([-1.0, 0.0]))  # x0 = 0: fine
    assert info["ok"] is True and info["message"] == ""
    np.testing.assert_allclose(obs, [0.0, 0.0])  # f = (x0, x1^2) = (0, 0)
    assert reward == pytest.approx(0.0)  # g = x1 - 0.5 < 0: feasible, no penalty


class NotFinite(Problem):
    """Claims success but returns an infinite objective: the env must not trust it."""

    name = "NotFinite"

    def __init__(self):
        self.space = DesignSpace([Parameter("x", 0.0, 1.0)])
        self.objective_names = ("f",)

    def _evaluate(self, X):
        n = len(X)
        return EvaluationBatch(
            np.full((n, 1), np.inf), np.zeros((n, 0)), np.ones(n, bool), [""] * n
        )


def test_failed_reward_follows_the_lowest_seen_and_vector_reward():
    env = ProblemEnv(Flaky(), budget=5, penalty=10.0)
    env.reset(seed=0)
    _, r, _, _, _ = env.step(np.array([-1.0, 1.0]))  # x = (0, 1): f = (0, 1), g = 0.5
    assert r == pytest.approx(-(1.0 + 10 * 0.5))
    _, r_fail, _, _, _ = env.step(np.array([0.8, 0.0]))
    assert r_fail == pytest.approx(-6.0 - (0.6 + 1.0)) and np.isfinite(r_fail)
    # MO-Gymnasium's convention: one reward per objective, each maximised
    vec = ProblemEnv(Flaky(), budget=5, reward="vector", penalty=10.0)
    vec.reset(seed=0)
    assert vec.reward_dim == 2 and vec.reward_space.shape == (2,)
    _, r, _, _, _ = vec.step(np.array([-1.0, 1.0]))
    np.testing.assert_allclose(r, [-(0.0 + 5.0), -(1.0 + 5.0)])
    _, r_fail, _, _, info = vec.step(np.array([0.8, 0.0]))
    assert info["ok"] is False
    # lowest per component: (-5, -6) against the reference's (-0.5, 0)
    np.testing.assert_allclose(r_fail, [-5.0 - 1.5, -6.0 - 1.6])
    venv = ProblemVectorEnv(Flaky(), num_envs=2, reward="vector")
    venv.reset(seed=0)
    assert venv.step(np.zeros((2, 2)))[1].shape == (2, 2)
    with pytest.raises(ValidationError, match="reward='vector' needs two or more objectives"):
        ProblemEnv("Sphere", reward="vector")


def test_complex_actions_are_refused_not_truncated():
    env = ProblemEnv(Flaky())
    env.reset(seed=0)
    with pytest.raises(ValidationError, match="real numbers, but got complex"):
        env.step(np.array([0.1 + 0.5j, 0.0]))


def test_non_finite_objectives_count_as_failed():
    env = ProblemEnv(NotFinite())
    obs, info = env.reset(seed=0)
    assert info["ok"] is False and "non-finite" in info["message"]
    assert obs in env.observation_space and obs[0] == FAIL_VALUE


def test_bad_actions_raise_clear_errors():
    env = ProblemEnv("CarSideImpact")
    env.reset(seed=0)
    with pytest.raises(ValidationError, match=r"finite, but component 2 \('floor_side_inner'\)"):
        env.step(np.array([0, 0, np.nan, 0, 0, 0, 0.0]))
    with pytest.raises(ValidationError, match=r"shape \(7,\), but got \(3,\)"):
        env.step(np.zeros(3))
    # finite values outside [-1, 1] are clipped to the bounds
    _, _, _, _, info = env.step(np.full(7, 5.0))
    np.testing.assert_allclose(list(info["parameters"].values()), env.problem.space.upper)


def test_rank_sum_needs_the_vector_env():
    with pytest.raises(ValidationError, match="use the vector env"):
        ProblemEnv("ZDT1", scalarizer="rank_sum")
    with pytest.raises(ValidationError, match="unknown scalarizer"):
        ProblemEnv("ZDT1", scalarizer="chebyshev")


# ------------------------------------------------------------- vector env
#: a sum of a few positive terms in two orders: within a few ulps (2.2e-16 each)
SUM_RTOL = 8 * np.finfo(float).eps


def test_vector_env_matches_single_env_row_by_row():
    n = 6
    vec = make_vector_env("CarSideImpact", num_envs=n, budget=4, weights=[1.0, 3.0, 2.0])
    singles = [make_env("CarSideImpact", budget=4, weights=[1.0, 3.0, 2.0]) for _ in range(n)]
    vobs, _ = vec.reset(seed=0)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(vobs[i], env.reset(seed=i)[0])
    rng = np.random.default_rng(5)
    for _ in range(4):
        A = rng.uniform(-1.2, 1.2, size=(n, 7))
        vobs, vrew, vterm, vtrunc, vinfo = vec.step(A)
        for i, env in enumerate(singles):
            sobs, srew, sterm, strunc, sinfo = env.step(A[i])
            np.testing.assert_array_equal(vobs[i], sobs)
            assert (vterm[i], vtrunc[i]) == (sterm, strunc)
            # the batch scalarises with a matrix product, one env with a dot product: the
            # same positive terms summed in another order (BLAS kernel, thread count)
            assert vrew[i] == pytest.approx(srew, rel=SUM_RTOL)
            assert vinfo["scalarized"][i] == pytest.approx(sinfo["scalarized"], rel=SUM_RTOL)
            for key in ("objectives", "constraints"):
                np.testing.assert_array_equal(vinfo[key][i], sinfo[key])
            for key in ("ok", "message", "violation", "evaluations"):
                assert vinfo[key][i] == sinfo[key], key
            params = {k: v[i] for k, v in vinfo["parameters"].items() if not k.startswith("_")}
            assert params == sinfo["parameters"]
    assert vtrunc.all()
    assert vinfo["_objectives"].all() and vinfo["parameters"]["_roof_rail"].all()


def test_vector_env_evaluates_a_population_in_one_call():
    counting = Counting(make_problem("ZDT1"))
    vec = ProblemVectorEnv(counting, num_envs=16, budget=3)
    vec.reset(seed=0)
    vec.step(vec.action_space.sample())
    vec.step(vec.action_space.sample())
    assert counting.calls == [1, 16, 16]  # reference once at reset, then one call per step


def test_vector_env_autoresets_on_the_step_after_truncation():
    vec = ProblemVectorEnv("Sphere", num_envs=2, problem_options={"dim": 2}, budget=1)
    first, _ = vec.reset(seed=0)
    _, _, _, trunc, _ = vec.step(np.ones((2, 2)))
    assert trunc.all()
    obs, reward, term, trunc, info = vec.step(np.ones((2, 2)))  # ignored: autoreset
    np.testing.assert_array_equal(obs, first)
    assert (reward == 0).all() and not term.any() and not trunc.any()
    assert (info["evaluations"] == 0).all()


def test_vector_env_rank_sum_is_tey_normalisation_of_the_batch():
    vec = ProblemVectorEnv("ZDT1", num_envs=5, scalarizer="rank_sum")
    vec.reset(seed=0)
    obs, reward, *_ = vec.step(np.random.default_rng(0).uniform(-1, 1, (5, 6)))
    # Tey et al. 2014: each objective min-max normalised over the batch to [0, 10], summed
    lo, hi = obs.min(axis=0), obs.max(axis=0)
    expected = (10 * (obs - lo) / (hi - lo)).sum(axis=1)
    np.testing.assert_allclose(-reward, expected, rtol=1e-12)


def test_vector_env_failed_rows_and_bad_actions():
    vec = ProblemVectorEnv(Flaky(), num_envs=3)
    vec.reset(seed=0)
    obs, reward, _, _, info = vec.step(np.array([[0.8, 0.0], [-1.0, 0.5], [-0.5, -0.5]]))
    np.testing.assert_array_equal(info["ok"], [False, True, True])
    # rows 1 and 2: f = (0, 0.25), (0.25, 0.25), feasible; the reference design -0.5
    np.testing.assert_allclose(reward[1:], [-0.25, -0.5])
    assert reward[0] == pytest.approx(-0.5 - 1.05) and "locks up" in info["message"][0]
    assert obs in vec.observation_space
    with pytest.raises(ValidationError, match=r"finite, but row 1 component 0 \('x0'\)"):
        vec.step(np.array([[0.0, 0.0], [np.inf, 0.0], [0.0, 0.0]]))
    with pytest.raises(ValidationError, match=r"shape \(3, 2\)"):
        vec.step(np.zeros((2, 2)))
    with pytest.raises(
        ValidationError, match="ProblemVectorEnv: `num_envs >= 1` must hold, but got num_envs=0"
    ):
        ProblemVectorEnv("Sphere", num_envs=0)


# --------------------------------------------------------------- rendering
def test_rgb_rendering_when_the_problem_can_draw():
    gym.register("suspenv-test/Painted-v0", entry_point=ProblemEnv, kwargs={"problem": Painted()})
    try:
        env = gym.make("suspenv-test/Painted-v0", render_mode="rgb_array", budget=5)
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            check_env(env.unwrapped)
        assert gym_warnings(record) == []
        env.reset(seed=0)
        env.step(np.array([0.0]))  # w = 0.5: the left half is painted
        frame = env.render()
        assert frame.dtype == np.uint8 and frame.shape == (8, 20, 3)
        assert (frame[:, :10, 0] == 255).all() and (frame[:, 10:, 0] == 0).all()
    finally:
        del gym.registry["suspenv-test/Painted-v0"]


def test_no_render_modes_without_render_rgb():
    env = ProblemEnv("ZDT1")
    assert env.metadata["render_modes"] == [] and env.render() is None
    with pytest.raises(ValidationError, match="defines no render_rgb"):
        ProblemEnv("ZDT1", render_mode="rgb_array")


def test_problems_registered_later_become_envs(monkeypatch):
    import suspenv.registry as registry

    monkeypatch.setitem(registry._PROBLEMS, "PaintedLate", Painted)
    try:
        env = make_env("PaintedLate", render_mode="rgb_array")
        assert isinstance(env.unwrapped.problem, Painted)
        assert "suspenv/PaintedLate-v0" in gym.registry
    finally:
        gym.registry.pop("suspenv/PaintedLate-v0", None)


def test_import_suspenv_registers_the_envs():
    # a fresh interpreter: `import suspenv` alone must make gym.make find the envs
    import subprocess
    import sys

    code = (
        "import gymnasium as gym, suspenv\n"
        "env = gym.make('suspenv/Sphere-v0')\n"
        "print(type(env.unwrapped).__name__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ProblemEnv"


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"penalty": -1.0}, "Sphere env: `penalty >= 0` must hold, but got penalty=-1.0"),
        (
            {"fail_value": np.inf},
            "`fail_value` must be a finite number with `0 <= fail_value <= 1e+300`, but got "
            "fail_value=inf",
        ),
        (
            {"reward": "sums"},
            "`reward` must be one of ['normalized', 'sum', 'vector'], but got "
            "'sums'; did you mean 'sum'?",
        ),
    ],
)
def test_env_options_are_refused_naming_the_rule_and_the_value(options, message):
    with pytest.raises(ValidationError) as err:
        ProblemEnv("Sphere", **options)
    assert message in str(err.value)
