"""The matrix-by-matrix rotation arithmetic of the K&C evaluation against its reference paths.

* the rotation updates of the Newton steps and the predictor (``rotation.ROWS_LAST``;
  reference: stacked matrix products of ``expm_so3`` and ``log_so3``);
* a whole rig run and the problem's objectives with the switch off: the same
  channels and objectives to the solver tolerance (``test_knc_speed_paths``' bounds).
"""

from __future__ import annotations

import numpy as np
import pytest
from knc_checks import channel_tolerance

import suspenv.models.mcpherson.rotation as rotation_module
import suspenv.models.mcpherson.solver as solver_module
from suspenv.models.mcpherson import build_axle, reference_design
from suspenv.models.mcpherson.rotation import expm_so3, log_so3, relative_log, turned
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import TESTS, run_tests


@pytest.fixture(scope="module")
def X():
    rng = np.random.default_rng(41)
    problem = KCIdentification()
    return np.vstack([reference_design(), problem.space.to_physical(rng.random((3, 49)))])


def test_rows_last_rotations_are_the_stacked_products():
    rng = np.random.default_rng(9)
    w = rng.normal(scale=0.05, size=(7, 2, 4, 3))
    w[0, 0, 0] = 0.0  # the series branch of expm and log
    A = expm_so3(rng.normal(scale=0.4, size=(7, 2, 4, 3)))
    B = expm_so3(rng.normal(scale=0.4, size=(7, 2, 4, 3)))
    # relative rotation vector and turned matrices: the stacked products to round-off
    ref = log_so3(np.matmul(A, np.swapaxes(B, -1, -2)))
    assert np.allclose(relative_log(A, B), ref, rtol=0, atol=1e-15)
    assert np.allclose(turned(w, A), np.matmul(expm_so3(w), A), rtol=0, atol=1e-15)


def test_run_and_objectives_match_the_reference_arithmetic(X, monkeypatch):
    # reference: the stacked rotation products (switch off); both with the shared
    # inverse Jacobian in double precision, so that the chord iterations of the two
    # arithmetics differ by their round-off only
    monkeypatch.setattr(solver_module, "SHARED_INVERSE_DTYPE", np.float64)
    problem = KCIdentification()
    axle = build_axle(X)
    fast = run_tests(axle, TESTS, steps=10)
    F_fast, ok_fast, _ = problem.simulate(X)
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


def test_default_is_the_rows_last_path():
    assert rotation_module.ROWS_LAST is True
