"""The K&C evaluation's memory bounds change no number (bitwise against their reference
paths) and keep a single candidate's evaluation small.

* the finite-difference Jacobian's perturbations in blocks of at most
  ``solver.JACOBIAN_PERTURBATIONS`` (reference: all 24 in one residual call);
* a solver of rows that are all one design holds that design's arrays once
  (zero-stride views; reference: a solver built from the repeated design);
* the two-leg loop's channels in calls of at most ``knc.OUTPUT_STATES`` states
  (reference: one call for all grid points);
* the objectives fitted one test at a time (reference: one fit per objective).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from knc_checks import off_equilibrium

import suspenv.models.mcpherson.solver as solver_module
import suspenv.rigs.knc as rig_module
from suspenv.metrics.knc import _objectives_one_by_one, objectives
from suspenv.models.mcpherson import AxleSolver, build_axle, reference_design
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import run_tests


@pytest.fixture(scope="module")
def X():
    rng = np.random.default_rng(33)
    problem = KCIdentification()
    return np.vstack([reference_design(), problem.space.to_physical(rng.random((2, 49)))])


@pytest.mark.parametrize("per", [1, 5, 12])
def test_jacobian_in_perturbation_blocks_is_the_one_call_jacobian(X, per, monkeypatch):
    solver = AxleSolver(build_axle(X[:1]))  # one row: the block size of a single candidate
    st, pad, ext, rack = off_equilibrium(solver, 5)
    monkeypatch.setattr(solver_module, "JACOBIAN_PERTURBATIONS", 1 << 30)
    whole = solver.jacobian(st, pad, ext, rack=rack)
    monkeypatch.setattr(solver_module, "JACOBIAN_PERTURBATIONS", per)
    assert np.array_equal(solver.jacobian(st, pad, ext, rack=rack), whole)


def test_rows_of_one_design_share_its_arrays(X):
    one = AxleSolver(build_axle(X[1:2]))
    rows = one.take(np.zeros(4, int), axle=False)
    assert rows.n == 4 and rows._vec.strides[0] == 0 and rows.K["lca_front"].strides[0] == 0
    again = rows.take(np.array([0, 3, 1]), axle=False)  # a take of shared rows shares too
    assert again.n == 3 and again._vec.strides[0] == 0
    # reference: the solver of the design repeated, every array a copy of its own
    ref = AxleSolver(build_axle(X[[1, 1, 1, 1]]))
    st, pad, ext, rack = off_equilibrium(ref, 5)
    for solver in (rows, ref):
        solver.stats = {"solves": 0, "residuals": 0, "jacobians": 0}
    res = rows.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)
    assert np.array_equal(res, ref.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack))
    a, conv_a, J_a = rows.solve(st, pad, ext, rack=rack)
    b, conv_b, J_b = ref.solve(st, pad, ext, rack=rack)
    assert conv_a.all() and np.array_equal(conv_a, conv_b)
    for name in ("r", "R", "lam"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert np.array_equal(J_a, J_b)
    out_a, out_b = rows.outputs(a, pad), ref.outputs(b, pad)
    assert all(np.array_equal(out_a[k], out_b[k]) for k in out_b)


def test_channels_in_small_output_calls_are_the_same_numbers(X, monkeypatch):
    axle = build_axle(X[:1])
    monkeypatch.setattr(rig_module, "OUTPUT_STATES", 1)  # one grid point per call
    small = run_tests(axle)
    monkeypatch.setattr(rig_module, "OUTPUT_STATES", 1 << 30)  # every grid point at once
    whole = run_tests(axle)
    for t, res in whole.items():
        assert res.ok.all() and np.array_equal(small[t].ok, res.ok)
        for name, v in res.channels.items():
            assert np.array_equal(small[t].channels[name], v), (t, name)
    # the objectives fitted test by test: those of one fit per objective
    assert np.array_equal(objectives(whole), _objectives_one_by_one(whole, {}))


def test_a_single_candidate_evaluation_stays_small(X):
    problem = KCIdentification()
    problem.evaluate(X[1:2])  # warm-up (imports, caches)
    tracemalloc.start()
    try:
        assert problem.evaluate(X[1:2]).ok.all()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # 0.35 MB before the blocked Jacobian, the shared design arrays, the small output
    # calls and the fits by test; about 0.17 MB with them
    assert peak < 0.25e6, peak
