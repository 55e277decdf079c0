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
from knc_checks import assert_same_residual, off_equilibrium

import suspenv.models.mcpherson.solver as solver_module
import suspenv.rigs.knc as rig_module
from suspenv.core import compiled
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
    assert rows.n == 4 and rows._vec_body[1].strides[0] == 0 and rows.K["lca_front"].strides[0] == 0
    again = rows.take(np.array([0, 3, 1]), axle=False)  # a take of shared rows shares too
    assert again.n == 3 and again._vec_body[1].strides[0] == 0
    # reference: the solver of the design repeated, every array a copy of its own
    ref = AxleSolver(build_axle(X[[1, 1, 1, 1]]))
    st, pad, ext, rack = off_equilibrium(ref, 5)
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


def test_a_batch_of_fourteen_designs_takes_its_rows_right():
    # the compiled residual's offsets are 14 numbers: a solver of 14 designs once took
    # them as rows, and a subset of its rows then read its pack at scrambled offsets (a
    # crash of the static solve of any batch of 14). Reference: each design's residual
    # in a solver of its own
    rng = np.random.default_rng(14)
    X = KCIdentification().space.to_physical(rng.random((14, 49)))
    solver = AxleSolver(build_axle(X))
    st = solver.initial_state()  # (no solve: its subsets would read the offsets)
    pad = solver.pad_static + 0.01
    ext = rng.normal(scale=300.0, size=(14, 2, 9))
    whole = solver.residual(st.r, st.R, st.lam, pad, st, ext)  # makes the offsets
    rows = np.array([3, 5, 7, 11])
    sub = solver.take(rows, axle=False)
    assert np.array_equal(sub._rl_off, solver._rl_off)
    part = sub.residual(st.r[rows], st.R[rows], st.lam[rows], pad[rows], st.take(rows), ext[rows])
    assert_same_residual(part, whole[rows])
    i = rows[:1]
    own = AxleSolver(build_axle(X[i]))
    assert_same_residual(
        own.residual(st.r[i], st.R[i], st.lam[i], pad[i], st.take(i), ext[i]), whole[i]
    )
    # the evaluation of 14 candidates: each one's objectives as evaluated alone
    problem = KCIdentification(steps=10)
    F, ok, _ = problem.simulate(X)
    assert ok.all()
    for j in (0, 13):
        assert np.array_equal(problem.simulate(X[j : j + 1])[0][0], F[j])


def test_rows_repeating_the_designs_share_the_pack(X):
    # the rig's rows (test x design, then leg x test x design) repeat the designs in order:
    # they read the designs' packed arrays in place (row m reads column m % n). Reference:
    # the same rows with a pack copied per row (SHARE_ONE_DESIGN off), bitwise
    solver = AxleSolver(build_axle(X))
    st, pad, ext, rack = off_equilibrium(solver, 5)
    solver.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)  # makes the pack
    n = solver.n
    tiled = solver.take(np.tile(np.arange(n), 3), axle=False).take(
        np.tile(np.arange(3 * n), 2), axle=False
    )
    assert tiled._rl_pack is solver._rl_pack and tiled.n == 6 * n
    big = st.take(np.tile(np.arange(n), 6))
    args = (big.r, big.R, big.lam, np.tile(pad, (6, 1)), big, np.tile(ext, (6, 1, 1)))
    shared = tiled.residual(*args, rack=np.tile(rack, (6, 1)))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(solver_module, "SHARE_ONE_DESIGN", False)
        copied = solver.take(np.tile(np.arange(n), 6), axle=False)
        assert copied._rl_pack.shape[-1] == 6 * n
        assert np.array_equal(copied.residual(*args, rack=np.tile(rack, (6, 1))), shared)
    # a subset of shared rows takes its own columns (row 4 is design 4 % n)
    sub = tiled.take(np.array([4, 1]), axle=False)
    assert np.array_equal(sub._rl_pack, solver._rl_pack[..., np.array([4, 1]) % n])


def test_rotations_freed_along_the_legs_change_no_number(X, monkeypatch):
    monkeypatch.setattr(rig_module, "COMPILED_SWEEP", False)  # the numpy path
    # the two-leg loop frees the rotation matrices of the states behind the last (their
    # relative rotations are in the predictor's cache). Reference: the same run keeping
    # every state (keep_states, which frees nothing), bitwise
    axle = build_axle(X)
    freed = []
    real = rig_module._release_rotations
    monkeypatch.setattr(rig_module, "_release_rotations", lambda st: freed.append(1) or real(st))
    lean = run_tests(axle, steps=10)
    assert len(freed) > 0
    freed.clear()
    kept = run_tests(axle, steps=10, keep_states=True)
    assert not freed
    for t, res in kept.items():
        assert np.array_equal(lean[t].ok, res.ok)
        for name, v in res.channels.items():
            assert np.array_equal(lean[t].channels[name], v), (t, name)
    # a freed state's rotations cannot be read by mistake: any use fails
    st = kept["parallel"].states[0]
    rig_module._release_rotations(st)
    with pytest.raises(ValueError):
        np.matmul(st.R, np.swapaxes(kept["parallel"].states[1].R, -1, -2))


def test_channels_in_small_output_calls_are_the_same_numbers(X, monkeypatch):
    monkeypatch.setattr(rig_module, "COMPILED_SWEEP", False)  # the numpy path
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


def test_a_single_candidate_evaluation_stays_small(X, monkeypatch):
    problem = KCIdentification()
    problem.evaluate(X[1:2])  # warm-up (imports, caches, compiled loops)
    # the peak of the arrays numpy makes (tracemalloc), the compiled loops' own scratch
    # left out on both paths: numba's runtime takes it from CPython's raw allocator,
    # which tracemalloc traces, in a loop compiled at its first call (the sweep's 0.15 MB
    # for one design) and from C's malloc, which it does not, in the built extension.
    # The peak before each loop is kept, that of the loop's scratch (freed within it)
    # dropped by resetting the peak after the call; the peak with it is kept too
    peaks, with_scratch = [], []
    call = compiled.Lazy.__call__

    def scratch_left_out(lazy: compiled.Lazy, *args):
        peaks.append(tracemalloc.get_traced_memory()[1])
        out = call(lazy, *args)
        with_scratch.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.reset_peak()
        return out

    monkeypatch.setattr(compiled.Lazy, "__call__", scratch_left_out)
    tracemalloc.start()
    try:
        assert problem.evaluate(X[1:2]).ok.all()
        peak = max(peaks + [tracemalloc.get_traced_memory()[1]])
    finally:
        tracemalloc.stop()
    assert peaks  # the evaluation ran compiled loops (else nothing was left out)
    # 0.35 MB before the blocked Jacobian, the shared design arrays, the small output
    # calls and the fits by test; about 0.17 MB with them; about 0.1 MB with the shared
    # inverse Jacobian in single precision, the channels of the fit window only and the
    # designs' arrays read in place (the benchmark states the target, 0.1 MB, per
    # candidate: this guard only catches a return to the old footprint)
    assert peak < 0.13e6, peak
    # with the scratch (seen with the loops compiled at their first call,
    # SUSPENV_COMPILED=jit): about 0.2 MB; 0.23 MB when the sweep held every grid
    # point's state (benchmarks/knc_speed.py states the figure)
    assert max(with_scratch) < 0.215e6, max(with_scratch)
