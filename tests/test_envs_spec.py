"""Env spec sheets and the normalised reward (KCIdentification's default).

Reported: "The K&C env's default reward sums objectives in mixed units, 57 % of it from one
objective no action can move." Reproduced with ``reward="sum"`` (kept for old results),
fixed by the default ``reward="normalized"`` (rule in :mod:`suspenv.envs.scales`).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import ValidationError
from suspenv.envs import ProblemEnv, ProblemVectorEnv, env_id, make_vector_env
from suspenv.envs.adapter import MixedUnitsWarning
from suspenv.envs.scales import (
    SAMPLE_SEED,
    SAMPLE_SIZE,
    SPREAD_FRACTION,
    objective_scales,
)
from suspenv.envs.spec import SECTIONS, spec_sheet
from suspenv.registry import list_problems, make_problem

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def kc_env():
    env = gym.make("suspenv/KCIdentification-v0", budget=3)
    yield env
    env.close()


# ------------------------------------------------------------- the report
def test_sum_reward_is_dominated_by_an_objective_no_design_moves():
    """The report, reproduced: with the old reward ("sum") one objective, opp_roll_rate,
    is 57 % of the reference design's reward, and no design in a seeded sample moves it."""
    units = r"reward='sum' adds .* across units \(N\*m/deg, .*, mm/mm\)"
    with pytest.warns(MixedUnitsWarning, match=units):
        env = ProblemEnv("KCIdentification", reward="sum")
    obs, info = env.reset(seed=0)
    problem = env.problem
    j = problem.objective_names.index("opp_roll_rate")
    assert info["scalarized"] == pytest.approx(obs.sum(), rel=1e-12)
    assert obs[j] / obs.sum() == pytest.approx(0.57, abs=0.01)
    # its spread over 64 random designs is below 0.1 % of its value: no action moves it
    U = np.random.default_rng(1).uniform(size=(64, problem.space.dim))
    F = problem.evaluate(problem.space.to_physical(U)).objectives
    assert np.ptp(F[:, j]) < 1e-3 * obs[j]


def test_normalised_reward_is_the_kc_default_in_standard_errors(kc_env):
    """One definition: the env's scales are the problem's declared standard errors (the
    scales of its quality), and the objective no design moves no longer dominates."""
    env = kc_env.unwrapped
    assert env.reward_mode == "normalized"
    obs, info = kc_env.reset(seed=0)
    s = env.objective_scales
    np.testing.assert_array_equal(s, env.problem.objective_scales)
    assert env.adapter.scales.declared
    shares = (np.abs(obs) / s) / (np.abs(obs) / s).sum()
    assert shares[env.problem.objective_names.index("opp_roll_rate")] < 0.01
    # the reward of a step: minus the sum of the objectives over their scales
    action = np.random.default_rng(2).uniform(-1, 1, env.problem.space.dim)
    obs, reward, *_, info = kc_env.step(action)
    assert info["ok"]
    assert reward == pytest.approx(-(obs / s).sum(), rel=1e-12)
    assert info["scalarized"] == pytest.approx((obs / s).sum(), rel=1e-12)


def test_the_old_reward_stays_available_and_reproduces_old_numbers():
    new = ProblemEnv("KCIdentification", budget=2)
    with pytest.warns(MixedUnitsWarning):
        old = ProblemEnv("KCIdentification", budget=2, reward="sum")
    new.reset(seed=0)
    old.reset(seed=0)
    a = np.zeros(new.problem.space.dim)
    obs_new, r_new, *_ = new.step(a)
    obs_old, r_old, *_ = old.step(a)
    np.testing.assert_array_equal(obs_new, obs_old)  # observations are never normalised
    assert r_old == pytest.approx(-obs_old.sum(), rel=1e-12)
    assert r_new != pytest.approx(r_old)


class Constant(Problem):
    """f0 = x (moves), f1 = 3 (no design moves it), f2 = 0 (matched everywhere)."""

    name = "Constant"

    def __init__(self):
        self.space = DesignSpace([Parameter("x", 0.0, 2.0, default=0.5)])
        self.objective_names = ("moves", "stuck", "zero")

    def _evaluate(self, X):
        n = len(X)
        F = np.c_[X[:, 0], np.full(n, 3.0), np.zeros(n)]
        return EvaluationBatch(F, np.zeros((n, 0)), np.ones(n, bool), [""] * n)


def test_scale_rule_by_hand():
    problem = Constant()
    scales = objective_scales(problem)
    # the fixed sample: 64 uniform designs, default_rng(0), x = 2 u
    u = np.random.default_rng(SAMPLE_SEED).uniform(size=(SAMPLE_SIZE, 1))[:, 0]
    q1, q3 = np.percentile(2 * u, [25, 75])
    # moves: max(|f(x_ref)| = 0.5, 0.1 * IQR); stuck: its reference value 3; zero: 1
    want = [max(0.5, SPREAD_FRACTION * (q3 - q1)), 3.0, 1.0]
    np.testing.assert_allclose(scales.scales, want, rtol=1e-12)
    assert scales.n_valid == SAMPLE_SIZE
    # an objective no design moves contributes exactly 1 wherever the agent goes
    env = ProblemEnv(Constant(), reward="normalized")
    env.reset(seed=0)
    for a in (-1.0, 0.3, 1.0):
        _, reward, *_, info = env.step(np.array([a]))
        x = info["parameters"]["x"]
        assert reward == pytest.approx(-(x / want[0] + 1.0), rel=1e-12)


def test_declared_scales_are_used_and_checked():
    class Declared(Constant):
        def __init__(self, scales):
            super().__init__()
            self._declared = scales

        @property
        def objective_scales(self):
            return self._declared

    env = ProblemEnv(Declared(np.array([2.0, 3.0, 0.5])), reward="normalized")
    env.reset(seed=0)
    _, reward, *_, info = env.step(np.array([1.0]))  # x = 2: f = (2, 3, 0)
    assert reward == pytest.approx(-(2 / 2.0 + 3 / 3.0 + 0 / 0.5), rel=1e-12)
    for bad in (np.array([1.0, 0.0, 1.0]), np.ones(2)):
        env = ProblemEnv(Declared(bad), reward="normalized")
        with pytest.raises(ValidationError, match="objective scales must be 3 finite numbers"):
            env.reset(seed=0)


def test_sum_reward_on_one_unit_does_not_warn(recwarn):
    ProblemEnv("ZDT1", reward="sum")
    assert not [w for w in recwarn if issubclass(w.category, MixedUnitsWarning)]


def test_scales_do_not_depend_on_the_agent():
    a = ProblemEnv("CarSideImpact", reward="normalized")
    b = ProblemEnv("CarSideImpact", reward="normalized")
    a.reset(seed=0)
    for _ in range(5):
        a.step(a.action_space.sample())
    b.reset(seed=123)
    np.testing.assert_array_equal(a.objective_scales, b.objective_scales)


def test_vector_env_normalised_matches_single_env_row_by_row():
    vec = make_vector_env("CarSideImpact", num_envs=4, budget=2, reward="normalized")
    single = ProblemEnv("CarSideImpact", budget=2, reward="normalized")
    vec.reset(seed=0)
    single.reset(seed=0)
    A = np.random.default_rng(3).uniform(-1, 1, (4, 7))
    _, vrew, *_ = vec.step(A)
    for i in range(4):
        # the same positive terms summed by a matrix product and by a dot product (BLAS
        # kernel, thread count): equal to a few ulps (2.2e-16 each), not bitwise
        assert vrew[i] == pytest.approx(single.step(A[i])[1], rel=8 * np.finfo(float).eps)
        single.reset()
    assert isinstance(vec.unwrapped, ProblemVectorEnv)
    assert vec.unwrapped.reward_mode == "normalized"


@pytest.mark.parametrize("reward", ["mean", 1, ""])
def test_bad_reward_is_refused(reward):
    with pytest.raises(
        ValidationError, match=r"`reward` must be one of \['normalized', 'sum', 'vector'\]"
    ):
        ProblemEnv("Sphere", reward=reward)


def test_import_suspenv_alone_makes_the_kc_env():
    code = (
        "import gymnasium as gym, suspenv\n"
        "env = gym.make('suspenv/KCIdentification-v0')\n"
        "print(type(env.unwrapped).__name__, env.unwrapped.reward_mode)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["ProblemEnv", "normalized"]


# ------------------------------------------------------------- spec sheets
@pytest.mark.parametrize("cls", [ProblemEnv, ProblemVectorEnv])
def test_env_docstrings_have_the_gymnasium_sections_in_order(cls):
    doc = cls.__doc__ or ""
    found = [doc.find(f"## {s}\n") for s in SECTIONS]
    assert all(i >= 0 for i in found), [s for s, i in zip(SECTIONS, found, strict=True) if i < 0]
    assert found == sorted(found)
    assert "normalized" in doc and '"sum"' in doc


@pytest.mark.parametrize("name", list_problems())
def test_every_env_has_a_spec_sheet_with_its_spaces(name):
    try:
        env = gym.make(env_id(name), budget=7)
    except ModuleNotFoundError as exc:  # a problem whose module is not written yet
        if exc.name and exc.name.startswith("suspenv"):
            pytest.skip(f"problem {name!r}: module {exc.name!r} does not exist yet")
        raise
    sheet = env.unwrapped.spec_sheet()
    headers = re.findall(r"^## (.+)$", sheet, flags=re.M)
    assert tuple(headers) == SECTIONS
    problem = env.unwrapped.problem
    assert f"({problem.space.dim},), float64)" in sheet
    assert f"({problem.n_objectives},), float64)" in sheet
    for p in problem.space.names:
        assert f"`{p}`" in sheet
    for o in problem.objective_names:
        assert f"`{o}`" in sheet
    assert f"reward mode **{env.unwrapped.reward_mode}**" in sheet
    assert "truncated` is True on step 7" in sheet


def test_spec_sheet_lists_the_scales_when_asked():
    sheet = spec_sheet("CarSideImpact", with_scales=True, reward="normalized")
    assert "scale s_j" in sheet and "reward mode **normalized**" in sheet


def test_docs_list_every_env_with_its_sizes_and_reward():
    text = (ROOT / "docs" / "envs.md").read_text()
    for name in list_problems():
        row = re.search(rf"^\| `suspenv/{name}-v0` \|(.+)$", text, flags=re.M)
        assert row, f"docs/envs.md has no row for suspenv/{name}-v0"
        problem = make_problem(name)
        cells = [c.strip() for c in row.group(1).split("|")]
        d, m, k, reward = cells[0], cells[1], cells[2], cells[3]
        assert (int(d), int(m), int(k)) == (
            problem.space.dim,
            problem.n_objectives,
            problem.n_constraints,
        ), name
        assert reward == ProblemEnv(problem).reward_mode, name
