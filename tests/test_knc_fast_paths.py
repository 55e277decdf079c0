"""The call-saving paths of the K&C evaluation against their reference paths.

Both are pure bookkeeping (the same operations on the same arrays, done fewer times),
so the comparison is exact (bitwise), not to a tolerance:

* the spring preload is sized with :class:`_OnePoseKinematics`, which computes the
  knuckle pose once per coordinate array instead of once per point and direction, and
  evaluates the twelve perturbed coordinate sets of its Jacobian in one call
  (``solver.PRELOAD_KINEMATICS``; reference: the plain ``CornerKinematics``);
* the quadratic predictor of the rig keeps its last relative rotation for the next
  step (``knc.PREDICTOR_CACHE``; reference: both rotations computed every step).
"""

from __future__ import annotations

import numpy as np
import pytest

import suspenv.models.mcpherson.solver as solver_module
import suspenv.rigs.knc as rig_module
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
from suspenv.models.mcpherson.kinematics import CornerKinematics
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import TESTS, run_tests


@pytest.fixture(autouse=True)
def numpy_sweep(monkeypatch):
    """The rig's numpy path (``knc.COMPILED_SWEEP = False``): its internals are checked
    here (the compiled sweep against it: ``test_knc_sweep_kernel``)."""
    monkeypatch.setattr(rig_module, "COMPILED_SWEEP", False)


@pytest.fixture(scope="module")
def X():
    rng = np.random.default_rng(11)
    problem = KCIdentification()
    return np.vstack([reference_design(), problem.space.to_physical(rng.random((3, 49)))])


@pytest.fixture()
def reference_paths(monkeypatch):
    def use() -> None:
        monkeypatch.setattr(solver_module, "PRELOAD_KINEMATICS", CornerKinematics)
        monkeypatch.setattr(rig_module, "PREDICTOR_CACHE", False)

    return use


def test_defaults_are_the_fast_paths():
    assert solver_module.PRELOAD_KINEMATICS is solver_module._OnePoseKinematics
    assert rig_module.PREDICTOR_CACHE is True


def test_one_pose_kinematics_sizes_the_same_preload(X, reference_paths):
    fast = AxleSolver(build_axle(X))
    reference_paths()
    ref = AxleSolver(build_axle(X))
    for name in ("L_free", "pad_static", "cp0", "spring_preload", "motion_ratio_kinematic"):
        assert np.array_equal(getattr(fast, name), getattr(ref, name)), name


def test_one_pose_kinematics_equations_match_the_plain_class(X):
    axle = build_axle(X)
    q = np.random.default_rng(2).normal(scale=1e-2, size=axle.camber0.shape + (6,))
    z = axle.points["wheel_centre"][..., 2] + 0.01
    plain, once = CornerKinematics(axle), solver_module._OnePoseKinematics(axle)
    assert np.array_equal(plain.equations(q, z), once.equations(q, z))
    # the twelve perturbed evaluations of the Jacobian in one batched call
    assert np.array_equal(plain.jacobian(q, z), once.jacobian(q, z))
    assert np.array_equal(plain.jacobian(q, z, h=1e-5), once.jacobian(q, z, h=1e-5))
    assert np.array_equal(plain.tangent(q, z), once.tangent(q, z))
    # a different array (even with the same values) is a new pose, never a stale one
    q2 = q + 1e-3
    assert np.array_equal(plain.point(q2, plain.B), once.point(q2, once.B))


@pytest.mark.parametrize("effects", ["none", "dahl"])
def test_cached_predictor_gives_the_same_channels(X, reference_paths, effects):
    eff = (
        [axle_effect("dahl_hysteresis", "bushings", f_c=50.0, sigma_ratio=3.0)]
        if effects == "dahl"
        else []
    )
    axle_rows = X if effects == "none" else X[:1]
    fast = run_tests(build_axle(axle_rows), TESTS, steps=10, effects=eff)
    reference_paths()
    ref = run_tests(build_axle(axle_rows), TESTS, steps=10, effects=eff)
    for t in TESTS:
        assert np.array_equal(fast[t].ok, ref[t].ok)
        assert fast[t].messages == ref[t].messages
        for name, v in ref[t].channels.items():
            assert np.array_equal(fast[t].channels[name], v, equal_nan=True), (t, name)


def test_problem_objectives_are_bitwise_those_of_the_reference_paths(X, reference_paths):
    problem = KCIdentification()
    fast = problem.simulate(X)
    reference_paths()
    ref = problem.simulate(X)
    assert np.array_equal(fast[1], ref[1]) and fast[2] == ref[2]
    assert np.array_equal(fast[0], ref[0], equal_nan=True)
