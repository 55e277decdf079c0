"""The K&C evaluation's faster solver paths against their reference paths.

* the Jacobian perturbs the lower-arm and strut-rod columns together (disjoint residual
  rows) and takes the constraint-multiplier columns exactly
  (reference: one forward difference per column, ``benchmarks/knc_reference.py``);
* the rig's rows share their design's static inverse Jacobian (``SharedInverse``;
  reference: one copy per row), Newton iterations evaluate only the rows still
  iterating (``solver.SUBSET_RESIDUALS``), the Jacobians are inverted in blocks of rows
  and the channels computed by name: all the same numbers (bitwise);
* a path-independent model solves its loop from the two legs side by side (the
  default ``reuse_revisits=True``): failures are reported as the sequential loop
  (``reuse_revisits=False``) reports them; its channels agree with it to the solver
  tolerance (``test_knc_speed_paths``);
* the objectives' quadratic fit in closed form against a least-squares solve.
"""

from __future__ import annotations

import numpy as np
import pytest

import suspenv.models.mcpherson.solver as solver_module
import suspenv.rigs.knc as rig_module
from benchmarks.knc_reference import jacobian_by_columns
from suspenv.core.errors import ValidationError
from suspenv.metrics.knc import quadratic_fit
from suspenv.models.mcpherson import AxleSolver, build_axle, reference_design
from suspenv.models.mcpherson.solver import NQ, NS, OUTPUT_NAMES, SharedInverse
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import TESTS, run_tests


@pytest.fixture(autouse=True)
def numpy_sweep(monkeypatch):
    """The rig's numpy path (``knc.COMPILED_SWEEP = False``): its internals are checked
    here (the compiled sweep against it: ``test_knc_sweep_kernel``)."""
    monkeypatch.setattr(rig_module, "COMPILED_SWEEP", False)


@pytest.fixture(scope="module")
def X():
    rng = np.random.default_rng(21)
    problem = KCIdentification()
    return np.vstack([reference_design(), problem.space.to_physical(rng.random((4, 49)))])


@pytest.fixture(scope="module")
def off_equilibrium(X):
    """A solver and a state moved off its static equilibrium, with wheel loads (force
    and moment at the contact points, a force at the wheel centres) and rack travel."""
    solver = AxleSolver(build_axle(X))
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    assert conv.all()
    rng = np.random.default_rng(4)
    st = solver._apply(st, rng.normal(scale=1e-3, size=(solver.n, 2 * NS)), conv)
    ext = rng.normal(scale=300.0, size=(solver.n, 2, 9))
    rack = rng.normal(scale=2e-3, size=(solver.n, 2))
    return solver, st, solver.pad_static + 0.01, ext, rack


#: columns of the body coordinates and of the multipliers in (x_left, x_right)
BODY = np.r_[0:NQ, NS : NS + NQ]
MULT = np.r_[NQ:NS, NS + NQ : 2 * NS]


def test_coloured_jacobian_equals_one_difference_per_column(off_equilibrium, monkeypatch):
    # reference: the forward-difference Jacobian with one perturbation per column
    solver, st, pad, ext, rack = off_equilibrium
    fast = solver.jacobian(st, pad, ext, rack=rack)
    monkeypatch.setattr(AxleSolver, "jacobian", jacobian_by_columns)
    ref = solver.jacobian(st, pad, ext, rack=rack)
    # shared perturbations of columns with disjoint rows: the very same differences
    assert np.array_equal(fast[:, :, BODY], ref[:, :, BODY])
    # multiplier columns: exact against a 1 N forward difference of a residual linear
    # in them, whose round-off is that of the kN-sized load sums (~1e-11 here)
    assert np.abs(ref[:, :, MULT]).max() > 0.5
    assert np.allclose(fast[:, :, MULT], ref[:, :, MULT], rtol=0, atol=1e-8)


def test_multiplier_columns_are_central_differences(off_equilibrium):
    # reference: central differences of the residual in each multiplier (the residual is
    # linear in them, so a 10 N step is exact up to round-off); a sign error fails here.
    # The tie-rod multiplier of a compliant steering system moves the rack and so both
    # sides' rows; with a rigid rack every multiplier enters its own side's rows only
    solver, st, pad, ext, rack = off_equilibrium
    rigid = solver.take(np.arange(solver.n), axle=False)
    rigid.C_rack = np.zeros(solver.n)
    rigid._rl_pack = None  # the pack again, with the rigid rack
    for model in (solver, rigid):
        J = model.jacobian(st, pad, ext, rack=rack)
        for s in (0, 1):
            for k in range(9):
                lp, lm = st.lam.copy(), st.lam.copy()
                lp[:, s, k] += 10.0
                lm[:, s, k] -= 10.0
                d = model.residual(st.r, st.R, lp, pad, st, ext, rack=rack) - model.residual(
                    st.r, st.R, lm, pad, st, ext, rack=rack
                )
                fd = d.reshape(model.n, 2 * NS) / 20.0
                assert np.abs(fd).max() > 0.1, k
                other = np.abs(fd[:, (1 - s) * NS : (2 - s) * NS]).max()
                rack_moves = k == 7 and model is solver  # not linear: forward vs central
                assert other > 0.01 if rack_moves else other == 0.0, (k, other)
                col = J[:, :, s * NS + NQ + k]
                tol = 1e-6 if rack_moves else 1e-8
                assert np.allclose(col, fd, rtol=0, atol=tol), (k, np.abs(col - fd).max())


def test_shared_inverse_is_one_copy_per_row(X):
    rng = np.random.default_rng(1)
    nd, groups = X.shape[0], 6
    base = rng.normal(size=(nd, 2 * NS, 2 * NS))
    res = rng.normal(size=(groups * nd, 2 * NS))
    shared = SharedInverse(base, groups, np.float64)  # bitwise against double precision
    per_row = base[np.tile(np.arange(nd), groups)]
    assert np.array_equal(shared.mul(res), np.matmul(per_row, res[..., None])[..., 0])
    # rows refreshed by the solver get their own matrix, the others keep the shared one
    rows = np.zeros(groups * nd, bool)
    rows[[2, 7, 11]] = True
    own = rng.normal(size=(3, 2 * NS, 2 * NS))
    shared.set(rows, own)
    per_row[rows] = own
    assert np.array_equal(shared.mul(res), np.matmul(per_row, res[..., None])[..., 0])
    rows[:] = False
    rows[7] = True  # a second refresh of a row overwrites its own matrix
    shared.set(rows, own[:1])
    per_row[7] = own[0]
    assert np.array_equal(shared.mul(res), np.matmul(per_row, res[..., None])[..., 0])
    assert shared.own.shape[0] == 3


def test_shared_inverse_in_single_precision_is_the_product_rounded():
    # the default precision (SHARED_INVERSE_DTYPE, single): half the memory, and every
    # product that of the matrices and residuals rounded to single precision, i.e. within
    # about 1e-7 of the double-precision product (reference: float32 numpy, float64 numpy)
    assert solver_module.SHARED_INVERSE_DTYPE is np.float32
    rng = np.random.default_rng(2)
    nd, groups = 3, 6
    base = rng.normal(size=(nd, 2 * NS, 2 * NS))
    res = rng.normal(size=(groups * nd, 2 * NS))
    shared = SharedInverse(base, groups)
    assert shared.base.dtype == np.float32 and shared.base.nbytes == base.nbytes // 2
    per_row = base[np.tile(np.arange(nd), groups)]
    single = np.matmul(per_row.astype(np.float32), res.astype(np.float32)[..., None])[..., 0]
    out = shared.mul(res)
    assert out.dtype == np.float64 and np.array_equal(out, single.astype(np.float64))
    double = np.matmul(per_row, res[..., None])[..., 0]
    scale = np.abs(per_row) @ np.abs(res)[..., None]
    assert np.abs(out - double).max() / scale.max() < 1e-6


def test_residuals_of_the_iterating_rows_only_change_nothing(X, monkeypatch):
    # reference: every row's residual at every iteration (SUBSET_RESIDUALS = False)
    axle = build_axle(np.vstack([X, X]))  # 10 rows: subsets once most have converged
    solver = AxleSolver(axle)
    fast, conv_fast, J_fast = solver.solve(solver.initial_state(), solver.pad_static)
    monkeypatch.setattr(solver_module, "SUBSET_RESIDUALS", False)
    ref, conv_ref, J_ref = solver.solve(solver.initial_state(), solver.pad_static)
    assert conv_ref.all() and np.array_equal(conv_fast, conv_ref)
    for name in ("r", "R", "lam"):
        assert np.array_equal(getattr(fast, name), getattr(ref, name)), name
    assert np.array_equal(J_fast, J_ref)


def test_blocked_inverse_is_the_whole_inverse(off_equilibrium, monkeypatch):
    solver, st, pad, ext, rack = off_equilibrium
    monkeypatch.setattr(solver_module, "JACOBIAN_BLOCK", 64)  # blocks of 2 rows
    blocked = solver.inverse_jacobian(st, pad, ext, rack=rack)
    monkeypatch.setattr(solver_module, "JACOBIAN_BLOCK", 1 << 62)
    whole = solver.inverse_jacobian(st, pad, ext, rack=rack)
    assert np.array_equal(blocked, whole)
    J = solver.jacobian(st, pad, ext, rack=rack)
    assert np.allclose(np.matmul(whole, J), np.eye(2 * NS), atol=1e-8)


def test_named_outputs_are_the_same_numbers(off_equilibrium):
    solver, st, pad, _, _ = off_equilibrium
    every = solver.outputs(st, pad)
    assert tuple(every) == OUTPUT_NAMES
    for names in (("toe",), ("caster", "pad_z"), ("spring_force", "arb_twist", "trail")):
        some = solver.outputs(st, pad, names)
        assert set(some) == set(names)
        for k, v in some.items():
            assert np.array_equal(v, every[k]), k


def test_run_tests_keeps_the_named_channels(X):
    axle = build_axle(X[:2])
    some = run_tests(axle, ("parallel",), steps=6, channels=("toe", "tyre_fz"))["parallel"]
    every = run_tests(axle, ("parallel",), steps=6)["parallel"]
    assert set(some.channels) == {"toe", "tyre_fz"}
    for k, v in some.channels.items():
        assert np.array_equal(v, every.channels[k]), k
    with pytest.raises(ValidationError, match="channels"):
        run_tests(axle, ("parallel",), steps=6, channels=("toe_angle",))


# ----------------------------------------------------------- failures on the legs


def _compare_failures(axle, steps=10):
    """The two-leg path against the sequential loop: same ok, same messages, and the
    failed rows' frozen channels equal to the solver tolerance (rad, m, N)."""
    legs = run_tests(axle, TESTS, steps=steps)
    loop = run_tests(axle, TESTS, steps=steps, reuse_revisits=False)
    for t in TESTS:
        assert np.array_equal(legs[t].ok, loop[t].ok), t
        assert legs[t].messages == loop[t].messages, t
        for name, tol in (("toe", 1e-5), ("wheel_centre_z", 1e-6), ("tyre_fz", 1.0)):
            err = np.abs(legs[t].channels[name] - loop[t].channels[name]).max()
            assert err <= tol, (t, name, err)
    return legs


def test_failures_at_design_and_at_bump_are_reported_as_by_the_loop():
    # row 1: no static equilibrium (an absurd corner load); rows 2, 3: a top mount too
    # soft to carry the bump end of the stroke (a lock-up at the last step of the first leg)
    axle = build_axle(np.tile(reference_design(), (4, 1)))
    axle.corner_load[1] = 1e7
    axle.bush["top_mount"][2:, :, :3] *= np.array([1e-3, 1e-2])[:, None, None]
    res = _compare_failures(axle)
    par = res["parallel"]
    assert par.ok.tolist() == [True, False, False, False]
    assert "static equilibrium" in par.messages[1]
    assert "LockupError" in par.messages[2] and "step 5 (stroke +40.00 mm)" in par.messages[2]


def test_a_failure_at_rebound_is_reported_at_its_step_of_the_loop(monkeypatch):
    # the bump end of the reference car deflects its bushings more than the rebound end,
    # so the check of the rebound end (the second leg) is made to fail for design 0: a
    # check rejecting every row of design 0 whose step is the rebound end of the stroke
    n = 2
    real = rig_module._check_state

    def check(solver, st, ok, msgs, at):
        real(solver, st, ok, msgs, at)
        for i in range(ok.size):
            where = at if isinstance(at, str) else at(i)
            if i % n == 0 and "stroke -40.00 mm" in where and ok[i]:
                msgs[i] = f"LockupError: rejected at {where}"
                ok[i] = False

    monkeypatch.setattr(rig_module, "_check_state", check)
    axle = build_axle(np.tile(reference_design(), (n, 1)))
    out = _compare_failures(axle)
    for t in TESTS:
        r = out[t]
        assert r.ok.tolist() == [False, True], t
        # path position 15 of 21: grid 0, the rebound end, first reached on the rebound leg
        assert r.messages[0] == "LockupError: rejected at step 15 (stroke -40.00 mm)", t
    _compare_window(axle, out)  # a failure outside the window, on the second leg


# ------------------------------------------------------------------ the window


def _compare_window(axle, full, window=2, steps=10):
    """A run keeping the window's channels only against ``full`` (every grid point) read
    at the loop's visits of the window's points: the same numbers, the same verdicts."""
    win = run_tests(axle, TESTS, steps=steps, window=window)
    kept = rig_module.window_steps(steps, window)
    i0 = steps // 2
    for t in TESTS:
        w, f = win[t], full[t]
        assert np.array_equal(w.grid, f.grid[i0 - window : i0 + window + 1]), t
        assert np.array_equal(w.path, rig_module.loop_path(2 * window)), t
        assert np.array_equal(f.path[kept], w.path + i0 - window), t  # the same points
        assert np.array_equal(w.ok, f.ok) and w.messages == f.messages, t
        assert set(w.channels) == set(f.channels), t
        for name, v in f.channels.items():
            assert np.array_equal(w.channels[name], v[:, kept]), (t, name)
    return win


def test_window_steps_are_the_loops_visits_of_the_window():
    # golden: steps 10 (grid 0..10, design at 5), window 2: design -> 7 (steps 0-2), down to
    # 3 (steps 9-12 of the loop 5..10, 9..0, 1..5), back up to 5 (steps 19, 20)
    assert rig_module.window_steps(10, 2).tolist() == [0, 1, 2, 9, 10, 11, 12, 19, 20]
    for steps, window in ((10, 5), (30, 3), (4, 1)):
        kept = rig_module.window_steps(steps, window)
        full = rig_module.loop_path(steps)
        assert np.array_equal(full[kept] - (steps // 2 - window), rig_module.loop_path(2 * window))
    # the whole grid: every step of the loop
    assert np.array_equal(rig_module.window_steps(10, 5), np.arange(21))


def test_a_window_keeps_the_channels_of_the_full_run_at_its_points():
    # reference: the same run keeping every grid point. Rows: the reference car, no static
    # equilibrium (an absurd corner load), a top mount too soft to carry the bump end (a
    # failure outside the window, on the first leg; its frozen state read inside it)
    axle = build_axle(np.tile(reference_design(), (3, 1)))
    axle.corner_load[1] = 1e7
    axle.bush["top_mount"][2:, :, :3] *= 1e-3
    full = run_tests(axle, TESTS, steps=10)
    assert full["parallel"].ok.tolist() == [True, False, False]
    _compare_window(axle, full)
    _compare_window(axle, full, window=5)  # the whole grid: the same result


def test_a_window_is_checked_and_left_to_the_two_leg_loop():
    axle = build_axle(reference_design()[None, :])
    for bad in (0, 6, 2.0, True, "3"):
        with pytest.raises(ValidationError, match="window"):
            run_tests(axle, TESTS, steps=10, window=bad)
    # the sequential loop keeps every grid point (a path-dependent model's branches
    # differ at the window's edges)
    loop = run_tests(axle, TESTS, steps=10, reuse_revisits=False, window=2)
    assert loop["parallel"].grid.size == 11 and loop["parallel"].path.size == 21


def test_the_problems_objectives_from_the_window_are_those_of_every_point(X):
    # reference: the same problem keeping the channels of every grid point
    problem = KCIdentification(steps=10)
    F, ok, msgs = problem.simulate(X)
    problem.window = None
    F_all, ok_all, msgs_all = problem.simulate(X)
    assert ok.all() and np.array_equal(ok, ok_all) and msgs == msgs_all
    assert np.array_equal(F, F_all)


# ------------------------------------------------------------------ the fit


def test_closed_form_fit_is_the_least_squares_solution():
    # reference: numpy's least-squares solver on the same 7-point windows
    rng = np.random.default_rng(8)
    x = np.sort(rng.normal(scale=5.0, size=(50, 11)), axis=-1)
    y = 0.3 + 2.0 * x - 0.05 * x**2 + rng.normal(scale=0.1, size=x.shape)
    v, s, c = quadratic_fit(x, y, 5)
    for i in range(x.shape[0]):
        xs = x[i, 2:9] - x[i, 5]
        A = np.stack([np.ones_like(xs), xs, xs * xs], axis=-1)
        coef = np.linalg.lstsq(A, y[i, 2:9], rcond=None)[0]
        assert np.allclose([v[i], s[i], c[i]], coef * [1, 1, 2], rtol=1e-9, atol=1e-12)
    # degenerate windows (no spread, non-finite points) give NaN, not an error
    x[0] = 1.0
    y[1, 4] = np.nan
    v, s, c = quadratic_fit(x, y, 5)
    assert np.isnan([v[0], s[0], c[0], v[1], s[1], c[1]]).all()
    assert np.isfinite(v[2:]).all()


def test_cubic_predictor_continues_a_cubic_path_exactly():
    # reference: a path cubic in the step (positions, multipliers) with a steady
    # rotation about a fixed axis, which the four-state extrapolation continues exactly
    from suspenv.models.mcpherson.rotation import expm_so3
    from suspenv.models.mcpherson.solver import AxleState
    from suspenv.rigs.knc import _extrapolate

    rng = np.random.default_rng(5)
    c = rng.normal(size=(4, 3, 2, 4, 3))  # coefficients of 1, t, t^2, t^3
    cl = rng.normal(size=(4, 3, 2, 9))
    omega = rng.normal(scale=0.02, size=(3, 2, 4, 3))
    R0 = expm_so3(rng.normal(scale=0.3, size=(3, 2, 4, 3)))

    def at(t: float) -> AxleState:
        poly = sum(c[i] * t**i for i in range(4))
        lam = sum(cl[i] * t**i for i in range(4))
        return AxleState(poly, np.matmul(expm_so3(t * omega), R0), lam)

    ok = np.ones(3, bool)
    pred = _extrapolate(at(3.0), at(2.0), at(1.0), ok, {}, at(0.0))
    want = at(4.0)
    assert np.allclose(pred.r, want.r, rtol=0, atol=1e-10)
    assert np.allclose(pred.lam, want.lam, rtol=0, atol=1e-10)
    assert np.allclose(pred.R, want.R, rtol=0, atol=1e-12)
    # a quadratic (three states) does not continue it: the test can fail
    quad = _extrapolate(at(3.0), at(2.0), at(1.0), ok, {})
    assert np.abs(quad.r - want.r).max() > 1e-3
