"""The compiled two-leg sweep (``suspenv.models.mcpherson.sweep_kernel``, the rig's path for
an axle without placed effects) against the rig's numpy path.

Reference: the same rig run with ``knc.COMPILED_SWEEP = False`` (the sweep driven from
Python, vectorised over the rows, kept as the reference path). Both converge every step
to the solver's tolerance (1e-6 m, 1e-5 rad, 0.1 N) from slightly different Jacobians
(the compiled one inverted by its sides' blocks, multiplier columns by differences), so their
channels agree to the channel's tolerance (``knc_checks.channel_tolerance``), not to
the bit. Failures: a design the compiled sweep flags is run through the numpy path,
so its messages are the numpy path's, word for word.
"""

from __future__ import annotations

import numpy as np
import pytest
from knc_checks import channel_tolerance

import suspenv.models.mcpherson.solver as solver_module
import suspenv.rigs.knc as rig_module
from suspenv.core.errors import ValidationError
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import ALL_TESTS, TESTS, run_tests

pytestmark = pytest.mark.skipif(not rig_module.compiled.AVAILABLE, reason="numba missing")


@pytest.fixture(scope="module")
def axle():
    rng = np.random.default_rng(5)
    X = np.vstack([reference_design(), KCIdentification().space.to_physical(rng.random((3, 49)))])
    return build_axle(X)


def _both(monkeypatch, *args, **kwargs):
    compiled = run_tests(*args, **kwargs)
    monkeypatch.setattr(rig_module, "COMPILED_SWEEP", False)
    reference = run_tests(*args, **kwargs)
    monkeypatch.setattr(rig_module, "COMPILED_SWEEP", True)
    return compiled, reference


def _assert_close(compiled, reference):
    for t, ref in reference.items():
        got = compiled[t]
        assert np.array_equal(got.ok, ref.ok) and got.messages == ref.messages, t
        assert np.array_equal(got.grid, ref.grid) and np.array_equal(got.path, ref.path)
        assert set(got.channels) == set(ref.channels)
        for name, v in ref.channels.items():
            assert got.channels[name].shape == v.shape
            err = np.abs(got.channels[name][ref.ok] - v[ref.ok]).max(initial=0.0)
            assert err <= channel_tolerance(name), (t, name, err)
            # a failed design's channels: the numpy path's (its last converged states)
            assert np.array_equal(got.channels[name][~ref.ok], v[~ref.ok], equal_nan=True)
        # the design position's hard points (the geometric roll centre reads them)
        assert set(got.static_points) == set(ref.static_points)
        for name, v in ref.static_points.items():
            err = np.abs(got.static_points[name][ref.ok] - v[ref.ok]).max(initial=0.0)
            assert err <= channel_tolerance("wheel_centre_z"), (t, name, err)


@pytest.mark.parametrize("window", [None, 3])
def test_every_test_agrees_with_the_numpy_path(axle, window, monkeypatch):
    # travel, force, traction (nine load columns), aligning and steering (rack) tests
    _assert_close(*_both(monkeypatch, axle, ALL_TESTS, steps=10, window=window))


def test_the_problems_channels_agree_with_the_numpy_path(axle, monkeypatch):
    names = ("toe", "camber", "tyre_fz", "wheel_centre_y")
    _assert_close(*_both(monkeypatch, axle, TESTS, channels=names, window=5))


def test_a_compliant_rack_agrees_with_the_numpy_path(monkeypatch):
    # the tie-rod columns: the rack moves with both tie rods (not linear in them)
    ax = build_axle(reference_design()[None, :])
    ax.rack_compliance = np.array([2e-6])
    _assert_close(*_both(monkeypatch, ax, ("steering", "lateral"), steps=10))


def test_flagged_designs_are_run_and_worded_by_the_numpy_path(axle, monkeypatch):
    # limits every design exceeds at the bump end: each is flagged by the compiled
    # sweep and reported with the numpy path's message
    monkeypatch.setattr(solver_module, "MAX_TRANSLATION", 1e-5)
    compiled, reference = _both(monkeypatch, axle, TESTS, steps=10)
    assert not reference["parallel"].ok.any()
    assert "LockupError" in reference["parallel"].messages[0]
    _assert_close(compiled, reference)


def test_the_sweep_refuses_placed_effects(axle):
    eff = [axle_effect("cubic_stiffness", "lower_arm", ratio=0.5)]
    with pytest.raises(ValidationError, match="placed effects"):
        AxleSolver(axle, eff).two_leg_sweep(np.zeros((1, 3, 2)), None, None, slice(None))


def _coupled_sides(rng):
    """A (66, 66) matrix shaped like the sweep's Jacobian: two well-conditioned 33 x 33
    side blocks coupled in a 6 x 6 corner each way (the anti-roll bar's body)."""
    A = np.zeros((66, 66))
    for s in (slice(0, 33), slice(33, 66)):
        A[s, s] = rng.normal(size=(33, 33)) + 12.0 * np.eye(33)
    A[18:24, 51:57] = rng.normal(size=(6, 6))
    A[51:57, 18:24] = rng.normal(size=(6, 6))
    return A


@pytest.mark.parametrize("side_singular", [False, True])
def test_the_block_inverse_is_the_inverse(side_singular):
    # reference: the product with the matrix is the identity to the round-off of an
    # elimination of order n (n^2 eps times the condition number: a generous bound on
    # partial pivoting's backward error at these sizes); a singular side block (the
    # whole regular) takes the whole-matrix elimination
    from suspenv.models.mcpherson import sweep_kernel

    A = _coupled_sides(np.random.default_rng(11))
    if side_singular:
        A[:33, 0] = 0.0  # the side block's first column gone, the coupling keeps A regular
        A[40, 0] = 1.0
    got = A.copy()
    assert sweep_kernel._block_inverse(got, sweep_kernel._inverse_work())
    bound = 66**2 * np.finfo(float).eps * np.linalg.cond(A)
    assert np.abs(got @ A - np.eye(66)).max() <= bound
    A[5] = 0.0  # a zero row: singular
    assert not sweep_kernel._block_inverse(A.copy(), sweep_kernel._inverse_work())
