"""The compiled residual of linear bushings (``residual_kernel``) against the numpy forms.

Reference: the rows-last residual (``AxleSolver._residual_rows_last``) and the element
slot by element slot residual, which ``test_knc_rows_last.py`` checks against each other;
the compiled loop is a third writing of the same equations (row by row, loads summed in
another order), so all three agree to round-off of the load sums. The solver takes the
compiled loop by default where numba is installed (``solver.RESIDUAL_COMPILED``).
"""

from __future__ import annotations

import numpy as np
import pytest
from knc_checks import assert_same_residual, off_equilibrium

import suspenv.models.mcpherson.solver as solver_module
from suspenv.models.mcpherson import AxleSolver, build_axle, reference_design, residual_kernel
from suspenv.models.mcpherson.rotation import expm_so3
from suspenv.problems.kc_identification import KCIdentification

pytestmark = pytest.mark.skipif(not residual_kernel.AVAILABLE, reason="numba not installed")


@pytest.fixture(scope="module")
def X():
    rng = np.random.default_rng(43)
    problem = KCIdentification()
    return np.vstack([reference_design(), problem.space.to_physical(rng.random((3, 49)))])


@pytest.mark.parametrize("frames", [False, True])
def test_compiled_residual_is_the_rows_last_residual(X, frames, monkeypatch):
    orientation = {"lca_front": (10.0, 35.0, -20.0), "top_mount": (0.0, 15.0, 5.0)}
    solver = AxleSolver(build_axle(X, None, None, orientation if frames else None))
    st, pad, ext, rack = off_equilibrium(solver, 7)
    calls: list[int] = []
    kernel = residual_kernel.residual
    monkeypatch.setattr(residual_kernel, "residual", lambda *a: calls.append(1) or kernel(*a))
    for e, q in ((None, None), (ext[..., :6], None), (ext, rack)):
        fast = solver.residual(st.r, st.R, st.lam, pad, st, e, rack=q)
        args = (st.r, st.R, st.lam, pad)
        assert_same_residual(fast, solver._residual_rows_last(*args, e, q))
        assert_same_residual(fast, solver._residual_by_slots(*args, st, e, rack=q))
    assert len(calls) == 3  # the default path is the compiled one
    # perturbed copies on a leading axis (the Jacobian's calls), multipliers and pads
    # given per design row (broadcast), loads and rack per row
    rng = np.random.default_rng(3)
    r = st.r + rng.normal(scale=1e-4, size=(3,) + st.r.shape)
    R = np.matmul(expm_so3(rng.normal(scale=1e-3, size=(3,) + st.R.shape[:-1])), st.R)
    ext3 = np.broadcast_to(ext, (3,) + ext.shape) * rng.uniform(0.5, 1.5, size=(3, 1, 1, 1))
    fast = solver.residual(r, R, st.lam, pad, st, ext3, rack=rack)
    assert_same_residual(fast, solver._residual_rows_last(r, R, st.lam, pad, ext3, rack))


def test_compiled_residual_of_taken_rows(X):
    # a taken solver reads its own rows of the per-design arrays
    solver = AxleSolver(build_axle(X))
    st, pad, ext, rack = off_equilibrium(solver, 8)
    solver.residual(st.r, st.R, st.lam, pad, st)
    for rows in (np.zeros(4, int), np.array([3, 1, 1, 0, 2])):
        sub, sst = solver.take(rows, axle=False), st.take(rows)
        args = (sst.r, sst.R, sst.lam, pad[rows])
        fast = sub.residual(*args, sst, ext[rows], rack=rack[rows])
        assert_same_residual(fast, sub._residual_rows_last(*args, ext[rows], rack[rows]))


def test_switch_off_takes_the_rows_last_residual(X, monkeypatch):
    solver = AxleSolver(build_axle(X[:2]))
    st, pad, _, _ = off_equilibrium(solver, 9)
    monkeypatch.setattr(solver_module, "RESIDUAL_COMPILED", False)
    monkeypatch.setattr(residual_kernel, "residual", lambda *a: 1 / 0)
    ref = solver._residual_rows_last(st.r, st.R, st.lam, pad, None, None)
    assert np.array_equal(solver.residual(st.r, st.R, st.lam, pad, st), ref)


def test_objectives_match_with_the_numpy_residual(X, monkeypatch):
    # the whole evaluation: the compiled residual changes round-off only, far inside the
    # solver tolerance (objectives to 1e-7 of their scale)
    problem = KCIdentification()
    F_fast, ok_fast, _ = problem.simulate(X)
    monkeypatch.setattr(solver_module, "RESIDUAL_COMPILED", False)
    F_ref, ok_ref, _ = problem.simulate(X)
    assert ok_fast.all() and ok_ref.all()
    scale = np.maximum(np.abs(F_ref).max(axis=0), 1e-9)
    assert np.max(np.abs(F_fast - F_ref) / scale) < 1e-7


@pytest.mark.parametrize("frames", [False, True])
def test_compiled_jacobian_is_the_block_jacobian(X, frames, monkeypatch):
    # reference: the same coloured perturbations in blocks through the residual (the
    # compiled one: the same residual numbers, the same turned rotations, so the very
    # same differences), and the column-by-column Jacobian of the numpy slot residual
    # (a forward difference per column, multipliers by a step)
    orientation = {"lca_front": (10.0, 35.0, -20.0), "top_mount": (0.0, 15.0, 5.0)}
    solver = AxleSolver(build_axle(X, None, None, orientation if frames else None))
    st, pad, ext, rack = off_equilibrium(solver, 10)
    fast = solver.jacobian(st, pad, ext, rack=rack)
    monkeypatch.setattr(solver_module, "JACOBIAN_COMPILED", False)
    blocks = solver.jacobian(st, pad, ext, rack=rack)
    scale = np.abs(blocks).max(axis=1, keepdims=True) + 1.0  # per column
    assert np.abs(blocks).max() > 1e3
    assert np.array_equal(fast, blocks)
    monkeypatch.setattr(solver_module, "RESIDUAL_COMPILED", False)
    monkeypatch.setattr(solver_module, "JACOBIAN_COLOURED", False)
    columns = solver.jacobian(st, pad, ext, rack=rack)
    # forward differences of step 1e-7 on residuals of a few kN: round-off / h
    assert np.max(np.abs(fast - columns) / scale) < 1e-8
