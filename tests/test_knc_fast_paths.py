"""The call-saving paths of the K&C evaluation against their reference paths.

* the spring preload is sized in closed form at the design position; reference: the
  ideal-joint ``CornerKinematics`` (scipy rotations) differenced numerically, to the
  finite differences' rounding error;
* the quadratic predictor of the rig keeps its last relative rotation for the next
  step (``knc.PREDICTOR_CACHE``; reference: both rotations computed every step), pure
  bookkeeping (the same operations on the same arrays, done fewer times), so the
  comparison is exact (bitwise).
"""

from __future__ import annotations

import numpy as np
import pytest
from mcpherson_kinematics import CornerKinematics

import suspenv.rigs.knc as rig_module
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
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
        monkeypatch.setattr(rig_module, "PREDICTOR_CACHE", False)

    return use


def test_defaults_are_the_fast_paths():
    assert rig_module.PREDICTOR_CACHE is True


def test_closed_form_preload_matches_the_kinematics_differenced(X):
    """The preload's motion against :class:`CornerKinematics`: its tangent (a central-
    difference Jacobian, h = 1e-7) and central differences (h = 1e-6) of the spring
    length and contact height along it. Their rounding, about 1e-16 m / 1e-7 relative to
    unit slopes, and truncation, h^2 times third derivatives of order 1/m, stay below
    1e-8; the closed form must agree to 1e-7 relative."""
    axle = build_axle(X)
    solver = AxleSolver(axle)
    p, kin, h = axle.points, CornerKinematics(axle), 1e-6
    dq = kin.tangent(np.zeros(axle.camber0.shape + (6,)), p["wheel_centre"][..., 2])

    def spring_and_contact(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        seat = np.linalg.norm(p["spring_upper_seat"] - kin.ST, axis=-1, keepdims=True)
        upper = kin.ST + kin.direction(q, kin.a) * seat
        length = np.linalg.norm(kin.point(q, p["spring_lower_seat"]) - upper, axis=-1)
        s = kin.direction(q, solver.s0)  # the contact point: Rw down the wheel plane
        down = s[..., 2:3] * s - np.array([0.0, 0.0, 1.0])
        down /= np.linalg.norm(down, axis=-1, keepdims=True)
        return length, (kin.point(q, p["wheel_centre"]) + axle.wheel_radius[..., None] * down)[
            ..., 2
        ]

    (lp, cp), (lm, cm) = spring_and_contact(h * dq), spring_and_contact(-h * dq)
    dL, dcp = (lp - lm) / (2 * h), (cp - cm) / (2 * h)
    assert np.allclose(solver.motion_ratio_kinematic, -dL, rtol=1e-7, atol=0.0)
    Fz = axle.corner_load + axle.wheel_weight
    preload = (Fz * dcp - axle.wheel_weight) / (-dL)
    # the preload as the solver keeps it: in the spring's free length
    assert np.allclose((solver.L_free - solver.L_spring0) * solver.ks, preload, rtol=1e-7, atol=0)
    assert np.allclose(solver.pad_static, spring_and_contact(0 * dq)[1] + Fz / axle.tyre_rate)


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
