"""The total constraint violation: dimensionless, ``sum_j max(g_j / s_j, 0)``.

Reference: the rule in :mod:`suspenv.core.result` (pymoo's CV on constraints normalised
by their limits), computed here by hand from the minibus's own measures (its ``extras``).
"""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import ValidationError
from suspenv.envs import ProblemEnv
from suspenv.problems.minibus import UNDERSTEER_SCALE, MinibusRideHandling

#: limits that make every kind of minibus constraint bind somewhere in a small sample
LIMITS = {"rms_limit": 0.8, "roll_limit_deg": 2.0, "min_understeer": 3.0}
LOADS = ("no_load", "full_load")


@pytest.fixture(scope="module")
def minibus():
    p = MinibusRideHandling(**LIMITS)
    X = p.space.to_physical(np.random.default_rng(0).uniform(size=(6, p.space.dim)))
    return p, X, p.evaluate(X)


def test_minibus_violation_by_hand(minibus):
    """Each term: how far the measure is beyond its limit, over the limit (aw [m/s^2],
    roll [deg]) or over 1 deg/g (understeer margin, whose limit may be 0)."""
    _, _, batch = minibus
    assert batch.ok.all()
    e = batch.extras
    for i in range(len(batch)):
        aw = sum(
            max(e[f"aw_{end}_{lc}"][i] - 0.8, 0.0) / 0.8
            for end in ("front", "rear")
            for lc in LOADS
        )
        roll = sum(max(e[f"roll_{lc}"][i] - 2.0, 0.0) / 2.0 for lc in LOADS)
        under = sum(max(3.0 - e[f"understeer_min_{lc}"][i], 0.0) / 1.0 for lc in LOADS)
        assert batch.violation[i] == pytest.approx(aw + roll + under, rel=1e-12, abs=1e-15)
    # design 0 (measured): aw_rear_no_load 0.858 m/s^2, roll_full_load 3.50 deg,
    # understeer_min 1.53 / 0.23 deg/g: 0.072 + 0.748 + 1.474 + 2.767 = 5.06
    assert batch.violation[0] == pytest.approx(5.06, abs=0.05)
    assert UNDERSTEER_SCALE == 1.0


class RollInRadians(MinibusRideHandling):
    """The minibus with its roll constraints in rad (and their scales in rad)."""

    def __init__(self, **options):
        super().__init__(**options)
        s = list(self.constraint_scales)
        self._roll = [self.constraint_names.index(f"roll_{lc}") for lc in LOADS]
        for j in self._roll:
            s[j] = np.deg2rad(s[j])
        self.constraint_scales = tuple(s)

    def _evaluate(self, X):
        b = super()._evaluate(X)
        b.constraints[:, self._roll] = np.deg2rad(b.constraints[:, self._roll])
        return b


def test_a_change_of_unit_with_its_scale_leaves_the_total(minibus):
    p, X, batch = minibus
    rad = RollInRadians(**LIMITS).evaluate(X)
    assert not np.allclose(rad.constraints, batch.constraints)  # other numbers ...
    np.testing.assert_allclose(rad.violation, batch.violation, rtol=1e-12)  # ... same total
    np.testing.assert_array_equal(rad.feasible, batch.feasible)
    # the plain sum over units (the old total) changes with the unit
    plain = np.clip(batch.constraints, 0, None).sum(axis=1)
    plain_rad = np.clip(rad.constraints, 0, None).sum(axis=1)
    assert np.abs(plain - plain_rad).max() > 0.5


def test_feasibility_does_not_depend_on_the_scales():
    """Default minibus on a seeded sample: the feasible rows are those whose every
    constraint is <= 0, with or without the scales (feasible count as before)."""
    p = MinibusRideHandling()
    X = p.space.to_physical(np.random.default_rng(3).uniform(size=(24, p.space.dim)))
    b = p.evaluate(X)
    unscaled = EvaluationBatch(b.objectives, b.constraints, b.ok, b.messages)
    np.testing.assert_array_equal(b.feasible, unscaled.feasible)
    np.testing.assert_array_equal(b.feasible, b.ok & (b.constraints <= 0).all(axis=1))
    assert 0 < b.feasible.sum() < len(b)  # both kinds present: the test can fail
    assert ((b.violation == 0) == b.feasible).all()


class Box(Problem):
    """g = x - 1 [mm]; scale declared per instance."""

    name = "Box"

    def __init__(self, scales=()):
        self.space = DesignSpace([Parameter("x", 0.0, 4.0, "mm", default=2.0)])
        self.objective_names = ("x",)
        self.constraint_names = ("x_limit",)
        self.constraint_scales = scales
        self.calls = 0

    def _evaluate(self, X):
        self.calls += 1
        n = len(X)
        return EvaluationBatch(X[:, :1], X[:, :1] - 1.0, np.ones(n, bool), [""] * n)


def test_default_scale_is_one_and_bad_scales_are_refused_before_any_work():
    X = np.array([[3.0], [0.5]])
    np.testing.assert_array_equal(Box().evaluate(X).violation, [2.0, 0.0])
    np.testing.assert_array_equal(Box((4.0,)).evaluate(X).violation, [0.5, 0.0])
    for bad in ((0.0,), (1.0, 2.0), (np.inf,)):
        box = Box(bad)
        with pytest.raises(ValidationError, match="finite numbers > 0 .one per constraint"):
            box.evaluate(X)
        assert box.calls == 0


def test_scales_survive_take_concatenate_and_the_env():
    b = Box((4.0,)).evaluate(np.array([[3.0], [0.5], [2.0]]))
    np.testing.assert_array_equal(b.take([0, 2]).violation, [0.5, 0.25])
    both = EvaluationBatch.concatenate([b.take([2]), b.take([0])])
    np.testing.assert_array_equal(both.violation, [0.25, 0.5])
    env = ProblemEnv(Box((4.0,)), penalty=10.0)
    env.reset(seed=0)
    _, reward, *_, info = env.step(env.design_to_action(np.array([3.0])))
    assert info["violation"] == pytest.approx(0.5, rel=1e-12)
    assert reward == pytest.approx(-(3.0 + 10.0 * 0.5), rel=1e-12)


class TwoUnits(Problem):
    """f = |x - (3, 3)|^2; g0 = x0 - 1 [mm], scale 0.001 mm; g1 = x1 - 1 [m], scale 1000
    m: the scaled and the plain totals rank infeasible designs differently."""

    name = "TwoUnits"

    def __init__(self):
        self.space = DesignSpace([Parameter(f"x{i}", 0.0, 4.0, default=2.0) for i in (0, 1)])
        self.objective_names = ("f",)
        self.constraint_names = ("g0", "g1")
        self.constraint_scales = (0.001, 1000.0)

    def _evaluate(self, X):
        n = len(X)
        F = ((X - 3.0) ** 2).sum(axis=1)
        return EvaluationBatch(F[:, None], X - 1.0, np.ones(n, bool), [""] * n)


def test_a_resumed_run_sees_the_same_violation(tmp_path):
    """Rows replayed from the archive carry the problem's scales: a run stopped after
    batch 4 and resumed asks exactly the designs of an uninterrupted run (CMA-ES ranks
    infeasible designs by violation)."""
    from suspenv.registry import make_strategy
    from suspenv.runs.archive import RunArchive
    from suspenv.runs.loop import optimize

    p = TwoUnits()

    def stop(b, U, batch):
        if b == 4:
            raise RuntimeError("stop")

    with pytest.raises(RuntimeError, match="stop"):
        optimize(
            p,
            make_strategy("cmaes", p, seed=2, popsize=6),
            60,
            run_dir=tmp_path / "run",
            callbacks=[stop],
        )
    run = optimize(p, make_strategy("cmaes", p, seed=2, popsize=6), 60, run_dir=tmp_path / "run")
    ref = optimize(p, make_strategy("cmaes", p, seed=2, popsize=6), 60, run_dir=tmp_path / "ref")
    assert run.n_resumed == 30 and run.n_evaluations == ref.n_evaluations == 60
    with RunArchive(tmp_path / "run") as a, RunArchive(tmp_path / "ref") as b:
        np.testing.assert_array_equal(a.arrays()["unit"], b.arrays()["unit"])
