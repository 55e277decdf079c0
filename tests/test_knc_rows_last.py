"""The rows-last arithmetic of the K&C evaluation against its reference paths.

* the residual of linear bushings with every quantity held rows last
  (``solver.RESIDUAL_ROWS_LAST``; reference: the element slot by element slot residual,
  which also serves placed effects and the recorded element loads): the same equations
  summed in another order, so equal to round-off of the load sums;
* the rotation updates of the Newton steps and the predictor (``rotation.ROWS_LAST``;
  reference: stacked matrix products of ``expm_so3`` and ``log_so3``), and the rows-last
  forms of ``expm_so3`` and ``log_so3`` themselves (bitwise, element by element);
* a whole rig run and the problem's objectives with both switches off: the same
  channels and objectives to the solver tolerance (``test_knc_speed_paths``' bounds).
"""

from __future__ import annotations

import numpy as np
import pytest
from knc_checks import assert_same_residual, channel_tolerance, off_equilibrium

import suspenv.models.mcpherson.rotation as rotation_module
import suspenv.models.mcpherson.solver as solver_module
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
from suspenv.models.mcpherson.rotation import (
    expm_rows_last,
    expm_so3,
    log_rows_last,
    log_so3,
    relative_log,
    turned,
)
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import TESTS, run_tests


@pytest.fixture(scope="module")
def X():
    rng = np.random.default_rng(41)
    problem = KCIdentification()
    return np.vstack([reference_design(), problem.space.to_physical(rng.random((3, 49)))])


@pytest.mark.parametrize("frames", [False, True])
def test_rows_last_residual_is_the_slot_residual(X, frames):
    orientation = {"lca_front": (10.0, 35.0, -20.0), "top_mount": (0.0, 15.0, 5.0)}
    solver = AxleSolver(build_axle(X, None, None, orientation if frames else None))
    assert (solver._Q is not None) == frames
    st, pad, ext, rack = off_equilibrium(solver, 6)
    for e, q in ((None, None), (ext[..., :6], None), (ext, rack)):
        fast = solver.residual(st.r, st.R, st.lam, pad, st, e, rack=q)
        ref = solver._residual_by_slots(st.r, st.R, st.lam, pad, st, e, rack=q)
        assert_same_residual(fast, ref)
    # perturbed copies on a leading axis (the Jacobian's calls), multipliers broadcast
    rng = np.random.default_rng(2)
    r = st.r + rng.normal(scale=1e-4, size=(3,) + st.r.shape)
    R = np.matmul(expm_so3(rng.normal(scale=1e-3, size=(3,) + st.R.shape[:-1])), st.R)
    fast = solver.residual(r, R, st.lam, pad, st, ext, rack=rack)
    assert_same_residual(fast, solver._residual_by_slots(r, R, st.lam, pad, st, ext, rack=rack))


def test_rows_last_residual_of_taken_rows(X):
    # a taken solver's arrays (rows of one design shared, rows of several copied), after
    # the parent has made its rows-last arrays: the taken rows' own
    solver = AxleSolver(build_axle(X))
    st, pad, ext, rack = off_equilibrium(solver, 6)
    solver.residual(st.r, st.R, st.lam, pad, st)  # the parent's rows-last arrays made
    for rows in (np.zeros(4, int), np.array([3, 1, 1, 0, 2])):
        sub, sst = solver.take(rows, axle=False), st.take(rows)
        fast = sub.residual(sst.r, sst.R, sst.lam, pad[rows], sst, ext[rows], rack=rack[rows])
        ref = sub._residual_by_slots(
            sst.r, sst.R, sst.lam, pad[rows], sst, ext[rows], rack=rack[rows]
        )
        assert_same_residual(fast, ref)


def test_effects_and_records_take_the_slot_residual(X, monkeypatch):
    axle = build_axle(X[:2])
    cubic = AxleSolver(axle, [axle_effect("cubic_stiffness", "lower_arm", ratio=0.5)])
    st, pad, ext, rack = off_equilibrium(cubic, 6)
    calls = []
    monkeypatch.setattr(AxleSolver, "_residual_rows_last", lambda *a, **k: calls.append(1) or 1 / 0)
    cubic.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)
    plain = AxleSolver(axle)
    plain.residual(st.r, st.R, st.lam, pad, st, ext, [], rack)  # a record
    assert not calls


def test_rows_last_rotations_are_the_stacked_products():
    rng = np.random.default_rng(9)
    w = rng.normal(scale=0.05, size=(7, 2, 4, 3))
    w[0, 0, 0] = 0.0  # the series branch of expm and log
    A = expm_so3(rng.normal(scale=0.4, size=(7, 2, 4, 3)))
    B = expm_so3(rng.normal(scale=0.4, size=(7, 2, 4, 3)))
    # the rows-last forms of expm_so3 and log_so3: element by element the same numbers
    E = expm_rows_last(np.moveaxis(w, -1, 0))
    assert np.array_equal(np.moveaxis(E, (0, 1), (-2, -1)), expm_so3(w))
    for M in (A, expm_so3(w)):
        lg = log_rows_last(np.moveaxis(M, (-2, -1), (0, 1)))
        assert np.array_equal(np.moveaxis(lg, 0, -1), log_so3(M))
    # relative rotation vector and turned matrices: the stacked products to round-off
    ref = log_so3(np.matmul(A, np.swapaxes(B, -1, -2)))
    assert np.allclose(relative_log(A, B), ref, rtol=0, atol=1e-15)
    assert np.allclose(turned(w, A), np.matmul(expm_so3(w), A), rtol=0, atol=1e-15)


def test_run_and_objectives_match_the_reference_arithmetic(X, monkeypatch):
    # reference: the slot residual and the stacked rotation products (both switches off);
    # both with the shared inverse Jacobian in double precision, so that the chord
    # iterations of the two arithmetics differ by their round-off only
    monkeypatch.setattr(solver_module, "SHARED_INVERSE_DTYPE", np.float64)
    problem = KCIdentification()
    axle = build_axle(X)
    fast = run_tests(axle, TESTS, steps=10)
    F_fast, ok_fast, _ = problem.simulate(X)
    monkeypatch.setattr(solver_module, "RESIDUAL_ROWS_LAST", False)
    monkeypatch.setattr(rotation_module, "ROWS_LAST", False)
    ref = run_tests(build_axle(X), TESTS, steps=10)
    F_ref, ok_ref, _ = problem.simulate(X)
    for t in TESTS:
        assert np.array_equal(fast[t].ok, ref[t].ok) and ref[t].ok.all()
        for name, v in ref[t].channels.items():
            err = np.abs(fast[t].channels[name] - v).max()
            assert err <= channel_tolerance(name), (t, name, err)
    assert ok_ref.all() and np.array_equal(ok_fast, ok_ref)
    # objectives [deg, mm, N, deg/mm ...]: the states agree far inside the tolerance
    # (about 1e-10 here), and so do the fitted objectives
    assert np.allclose(F_fast, F_ref, rtol=1e-6, atol=1e-8), np.abs(F_fast - F_ref).max()


def test_defaults_are_the_rows_last_paths():
    assert solver_module.RESIDUAL_ROWS_LAST is True
    assert rotation_module.ROWS_LAST is True
