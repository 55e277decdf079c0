"""The axle's residual (the compiled row loop ``residual_kernel``, the product's one
writing of the equations) against the plain-numpy reference ``tests/mcpherson_reference.py``.

Reference: the element slot by element slot residual in numpy (every element's load with
its arm, summed per body, the placed effects' loads computed there from the bushing
deflections). Both write the same equations, loads summed in another order, so they agree
to round-off of load sums of a few kN (``knc_checks.assert_same_residual``: 1e-8 N, N*m).
The states are off equilibrium (1 mm / 1 mrad noise) so that the comparison is not of
zeros; bushing frames, placed effects (cubic and Dahl bushings, strut friction with a
history), wheel loads and rack travel are each exercised.
"""

from __future__ import annotations

import mcpherson_reference as reference
import numpy as np
import pytest
from knc_checks import assert_same_residual, off_equilibrium

import suspenv.models.mcpherson.solver as solver_module
from benchmarks.knc_reference import jacobian_by_columns
from suspenv.core.errors import ValidationError
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
from suspenv.models.mcpherson.rotation import expm_so3
from suspenv.problems.kc_identification import KCIdentification

ORIENTATION = {"lca_front": (10.0, 35.0, -20.0), "top_mount": (0.0, 15.0, 5.0)}


@pytest.fixture(scope="module")
def X():
    rng = np.random.default_rng(43)
    problem = KCIdentification()
    return np.vstack([reference_design(), problem.space.to_physical(rng.random((3, 49)))])


def _effects() -> list:
    return [
        axle_effect("cubic_stiffness", "lower_arm", ratio=0.5, x_ref=0.002),
        axle_effect("dahl_hysteresis", "top_mount", f_c=40.0, sigma_ratio=3.0),
        axle_effect("coulomb_friction", "strut", f_c=60.0, sigma=2e5),
    ]


def _with_history(solver: AxleSolver, seed: int):
    """A state off equilibrium whose committed history lies 0.3 mm / 0.3 mrad away, so
    that the Dahl elements and the friction carry load."""
    st, pad, ext, rack = off_equilibrium(solver, seed)
    st = solver.commit(st)
    step = np.random.default_rng(seed).normal(scale=3e-4, size=(solver.n, 66))
    return solver._apply(st, step, np.ones(solver.n, bool)), pad, ext, rack


@pytest.mark.parametrize("frames", [False, True])
@pytest.mark.parametrize("effects", [False, True])
def test_residual_is_the_numpy_reference(X, frames, effects):
    axle = build_axle(X, None, None, ORIENTATION if frames else None)
    solver = AxleSolver(axle, _effects() if effects else ())
    st, pad, ext, rack = _with_history(solver, 7)
    assert (st.fric is not None) == effects
    for e, q in ((None, None), (ext[..., :6], None), (ext, rack)):
        fast = solver.residual(st.r, st.R, st.lam, pad, st, e, rack=q)
        ref = reference.residual(solver, st.r, st.R, st.lam, pad, st, e, rack=q)
        assert_same_residual(fast, ref)
    # perturbed copies on a leading axis (the Jacobian's calls), multipliers and pads
    # given per design row (broadcast), loads and rack per row
    rng = np.random.default_rng(3)
    r = st.r + rng.normal(scale=1e-4, size=(3,) + st.r.shape)
    R = np.matmul(expm_so3(rng.normal(scale=1e-3, size=(3,) + st.R.shape[:-1])), st.R)
    ext3 = np.broadcast_to(ext, (3,) + ext.shape) * rng.uniform(0.5, 1.5, size=(3, 1, 1, 1))
    fast = solver.residual(r, R, st.lam, pad, st, ext3, rack=rack)
    assert_same_residual(fast, reference.residual(solver, r, R, st.lam, pad, st, ext3, rack=rack))


def test_effects_change_the_residual(X):
    # the effects' loads reach the residual (not a comparison of two linear axles)
    axle = build_axle(X[:2])
    plain, rich = AxleSolver(axle), AxleSolver(axle, _effects())
    st, pad, ext, rack = _with_history(rich, 8)
    a = plain.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)
    b = rich.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)
    assert np.abs(a - b).max() > 1.0  # N: the cubic, Dahl and friction loads


def test_residual_of_taken_rows(X):
    # a taken solver reads its own rows of the per-design arrays
    solver = AxleSolver(build_axle(X))
    st, pad, ext, rack = off_equilibrium(solver, 8)
    solver.residual(st.r, st.R, st.lam, pad, st)
    for rows in (np.zeros(4, int), np.array([3, 1, 1, 0, 2])):
        sub, sst = solver.take(rows, axle=False), st.take(rows)
        args = (sst.r, sst.R, sst.lam, pad[rows], sst, ext[rows])
        fast = sub.residual(*args, rack=rack[rows])
        assert_same_residual(fast, reference.residual(sub, *args, rack=rack[rows]))


def test_states_of_other_rows_are_refused(X):
    solver = AxleSolver(build_axle(X[:2]))
    st, pad, _, _ = off_equilibrium(solver, 9)
    with pytest.raises(ValidationError, match="n = 2"):
        solver.residual(st.r[:1], st.R[:1], st.lam[:1], pad[:1], st)


@pytest.mark.parametrize("frames", [False, True])
def test_compiled_jacobian_is_the_block_jacobian(X, frames, monkeypatch):
    # reference: the same coloured perturbations in blocks through the residual (the
    # same residual numbers, the same turned rotations, so the very same differences),
    # and the column-by-column Jacobian (a forward difference per column, multipliers by
    # a step)
    solver = AxleSolver(build_axle(X, None, None, ORIENTATION if frames else None))
    st, pad, ext, rack = off_equilibrium(solver, 10)
    fast = solver.jacobian(st, pad, ext, rack=rack)
    monkeypatch.setattr(solver_module, "JACOBIAN_COMPILED", False)
    blocks = solver.jacobian(st, pad, ext, rack=rack)
    scale = np.abs(blocks).max(axis=1, keepdims=True) + 1.0  # per column
    assert np.abs(blocks).max() > 1e3
    assert np.array_equal(fast, blocks)
    monkeypatch.setattr(AxleSolver, "jacobian", jacobian_by_columns)
    columns = solver.jacobian(st, pad, ext, rack=rack)
    # forward differences of step 1e-7 on residuals of a few kN: round-off / h
    assert np.max(np.abs(fast - columns) / scale) < 1e-8
