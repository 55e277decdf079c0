"""K&C rig tests beyond vertical travel: traction, aligning moment, steering.

Each physics test says where its reference comes from: the solver's external-load path
with the equivalent load written out by hand, a direct loaded solve, the independent
ideal-joint kinematics (CornerKinematics) with a moved rack point, a first-order closed
form of the tie-rod geometry, and mirror symmetry of the reference axle.
"""

from __future__ import annotations

import mcpherson_reference as reference
import numpy as np
import pytest
from mcpherson_kinematics import CornerKinematics

from suspenv.core.errors import ValidationError
from suspenv.measurements.knc import (
    ALL_TESTS,
    DRIVE_UNIT,
    FORCE_TESTS,
    OPPOSED_TESTS,
    STEER_TESTS,
    TESTS,
    drive,
    drive_label,
    mirrored,
)
from suspenv.models.mcpherson import AxleSolver, build_axle, reference_design
from suspenv.models.mcpherson.params import BUSHINGS, PARAMETER_NAMES
from suspenv.models.mcpherson.rotation import log_so3
from suspenv.rigs.knc import (
    MOMENT_AMPLITUDE,
    RACK_AMPLITUDE,
    rack_travel,
    run_tests,
    wheel_loads,
)
from suspenv.rigs.knc_recording import from_recording, to_recording

NEW = ("traction", "aligning", "steering")
STEPS = 8
IDX = {n: i for i, n in enumerate(PARAMETER_NAMES)}


@pytest.fixture(scope="module")
def axle():
    return build_axle(reference_design()[None, :])


@pytest.fixture(scope="module")
def runs(axle):
    """The new tests and the longitudinal (braking) test of the reference axle."""
    res = run_tests(axle, (*NEW, "longitudinal"), steps=STEPS, keep_states=True)
    for t, r in res.items():
        assert r.ok.all(), (t, r.messages)
    return res


def kinematic_like(x: np.ndarray) -> np.ndarray:
    """Bushings stiff in translation (1e6 N/mm) and nearly free in rotation (1 N*mm/deg)
    (as in tests/test_knc_solver.py): the compliant model's ideal-joint limit."""
    x = x.copy()
    for b, comps in BUSHINGS.items():
        for c in comps:
            x[IDX[f"{b}_{c}"]] = 1e6 if c.startswith("k") else 1.0
    return x


# ---------------------------------------------------------------- names and units


def test_test_names_units_and_grids(runs):
    assert (*TESTS, "lateral", "longitudinal", "traction", "aligning", "steering") == ALL_TESTS
    assert FORCE_TESTS == ("lateral", "longitudinal", "traction", "aligning")
    assert STEER_TESTS == ("steering",)
    assert set(DRIVE_UNIT) == set(ALL_TESTS) | set(OPPOSED_TESTS)
    assert all(DRIVE_UNIT[o] == DRIVE_UNIT[p] for o, p in OPPOSED_TESTS.items())
    want = {"traction": ("N", 2500.0), "aligning": ("N*m", 250.0), "steering": ("m", 0.030)}
    for t, (unit, amp) in want.items():
        r = runs[t]
        assert r.unit == unit == DRIVE_UNIT[t]
        assert r.grid.size == STEPS + 1 and r.grid[0] == -amp and r.grid[-1] == amp
        # loop design -> +end -> -end -> design, the pads held at their static height
        g = r.grid[r.path]
        assert g[0] == 0.0 and g[STEPS // 2] == amp and g[STEPS // 2 + STEPS] == -amp
        assert g[-1] == 0.0
        assert np.ptp(r.channels["pad_z"]) == 0.0
    assert MOMENT_AMPLITUDE == 250.0 and RACK_AMPLITUDE == 0.030


def test_amplitudes_are_validated(axle):
    with pytest.raises(ValidationError, match="moment_amplitude > 0"):
        run_tests(axle, ("aligning",), moment_amplitude=0.0)
    with pytest.raises(ValidationError, match="rack_amplitude > 0"):
        run_tests(axle, ("steering",), rack_amplitude=-0.01)


def test_load_and_rack_vectors_of_each_test():
    # golden: where each test's drive enters (ISO 8855 columns, both wheels alike)
    assert np.array_equal(wheel_loads("traction", 2.0)[:, 6], [2.0, 2.0])
    assert np.count_nonzero(wheel_loads("traction", 2.0)) == 2
    assert np.array_equal(wheel_loads("aligning", 3.0)[:, 5], [3.0, 3.0])
    assert np.count_nonzero(wheel_loads("aligning", 3.0)) == 2
    assert np.array_equal(wheel_loads("longitudinal", 1.0)[:, 0], [1.0, 1.0])
    assert np.array_equal(rack_travel("steering", 0.01), [0.01, 0.01])
    assert not rack_travel("traction", 0.01).any() and not wheel_loads("steering", 1.0).any()


# ---------------------------------------------------------------- solver inputs


def test_zero_rack_and_zero_centre_force_leave_the_residual_bitwise_unchanged(axle):
    # the travel tests' results cannot move: the new inputs at zero add exact zeros
    solver = AxleSolver(axle)
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    assert conv.all()
    ext6 = wheel_loads("lateral", 300.0)[None, :, :6]
    base = solver.residual(st.r, st.R, st.lam, solver.pad_static, st, ext6)
    ext9 = np.concatenate([ext6, np.zeros((1, 2, 3))], axis=-1)
    zero = np.zeros((1, 2))
    same = solver.residual(st.r, st.R, st.lam, solver.pad_static, st, ext9, rack=zero)
    assert np.array_equal(base, same)


def test_travel_results_do_not_change_when_the_new_tests_share_the_batch(axle):
    # the rows of a batch are independent: the parallel test alone and in a batch with
    # every new test give the same loop (to far below the solver tolerance)
    alone = run_tests(axle, ("parallel", "lateral"), steps=STEPS)
    shared = run_tests(axle, ("parallel", "lateral", *NEW), steps=STEPS)
    for t in ("parallel", "lateral"):
        for ch in ("toe", "camber", "wheel_centre_z", "tyre_fz"):
            assert np.allclose(alone[t].channels[ch], shared[t].channels[ch], rtol=0, atol=1e-12)


# ---------------------------------------------------------------- traction


def test_traction_equals_the_braking_force_plus_the_moment_f_h_about_the_spin_axis(axle, runs):
    # reference: statics. A force F along +x at the wheel centre is the same force at the
    # loaded contact point P (where the rig's pad applies its loads: the wheel plane's
    # downward radius met with the pad plane) plus the moment (wc - P) x F, i.e. F*h about
    # +y (h the loaded radius, wheel centre above the pad) and -F*(wc - P)_y about +z.
    # Applied explicitly through the solver's contact-point load path and solved from the
    # static state in one go (an independent Newton solve), it must give the traction
    # test's state.
    solver = AxleSolver(axle)
    st0, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    assert conv.all()
    tr, lon = runs["traction"], runs["longitudinal"]
    k = int(np.flatnonzero(tr.grid[tr.path] == tr.grid[-1])[0])  # +2500 N
    F = tr.grid[-1]
    wc = np.stack([tr.channels[f"wheel_centre_{a}"][0, k] for a in "xyz"], axis=-1)
    cp = np.stack([tr.channels[f"contact_{a}"][0, k] for a in "xyz"], axis=-1)
    pad = tr.channels["pad_z"][0, k]
    P = wc + ((pad - wc[:, 2]) / (cp[:, 2] - wc[:, 2]))[:, None] * (cp - wc)
    arm = wc - P  # (2, 3): wheel centre - loaded contact point
    h = arm[:, 2]
    assert np.all((h > 0.25) & (h < 0.35))  # m: a loaded radius
    ext = np.zeros((1, 2, 6))
    ext[0, :, 0] = F
    ext[0, :, 3:] = np.cross(arm, [F, 0.0, 0.0])
    assert np.allclose(ext[0, :, 4], F * h)  # the moment F*h about +y
    st, conv, _ = solver.solve(st0, solver.pad_static, ext)
    assert conv.all()
    out = solver.outputs(st, solver.pad_static)
    for ch, atol in (("toe", 2e-6), ("camber", 2e-6), ("wheel_centre_x", 1e-6), ("tyre_fz", 0.5)):
        assert np.allclose(out[ch][0], tr.channels[ch][0, k], rtol=0, atol=atol), ch
    # the moment matters: braking (force at the contact point) and traction differ
    dtoe = np.abs(lon.channels["toe"][0, k] - tr.channels["toe"][0, k])
    assert (dtoe > 50 * 2e-6).all(), dtoe


def test_every_body_is_in_balance_under_the_new_loads(axle, runs):
    # reference: statics of each rigid body from the element loads re-evaluated at every
    # converged step, the applied wheel-centre force / contact moment / rack travel included
    solver = AxleSolver(axle)
    for t in NEW:
        r = runs[t]
        for k, st in enumerate(r.states):
            d = r.grid[r.path[k]]
            F, M = reference.body_loads(
                solver, st, solver.pad_static, wheel_loads(t, d)[None], rack=rack_travel(t, d)[None]
            )
            assert np.abs(F).max() < 0.05, (t, k)  # N, against kN loads
            assert np.abs(M).max() < 0.05, (t, k)  # N*m


# ---------------------------------------------------------------- aligning moment


def test_aligning_moment_turns_the_left_wheel_out_and_the_right_wheel_in(axle):
    # reference: a direct loaded solve from the static state (the moment applied in one
    # go) and the geometry of ISO 8855: a moment about +z turns a wheel's front towards
    # +y, outboard on the left wheel (toe-out, toe decreases), inboard on the right
    res = run_tests(axle, ("aligning",), steps=2, moment_amplitude=100.0)["aligning"]
    solver = AxleSolver(axle)
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    loaded, conv2, _ = solver.solve(
        st, solver.pad_static, wheel_loads("aligning", 100.0)[None, :, :6]
    )
    assert conv.all() and conv2.all()
    toe0 = solver.outputs(st, solver.pad_static)["toe"][0]
    toe = solver.outputs(loaded, solver.pad_static)["toe"][0]
    assert toe[0] < toe0[0] - 1e-5 and toe[1] > toe0[1] + 1e-5  # rad
    k = int(np.flatnonzero(res.grid[res.path] == 100.0)[0])
    assert np.allclose(res.channels["toe"][0, k], toe, rtol=0, atol=1e-9)


def test_aligning_own_sense_gives_equal_left_and_right_channels(runs):
    # reference: mirror symmetry of the reference axle. The own sense of
    # measurements.knc.drive (toe-out positive: +M on the left, -M on the right) must
    # put both wheels' channels on one curve; the ISO sense (+M on both) would not
    rec = to_recording(runs["aligning"])
    assert mirrored(rec) and drive_label(rec)[0].startswith("own toe-out moment")
    left, right = drive(rec, "left"), drive(rec, "right")
    assert np.array_equal(left, rec.inputs["force"] / MOMENT_AMPLITUDE)
    assert np.array_equal(right, -left)
    for ch in ("toe", "camber", "tyre_fz"):
        a, b = rec.outputs[f"{ch}_left"], rec.outputs[f"{ch}_right"]
        # equal own drive: the right wheel's sample at the mirrored grid point
        order_l, order_r = np.argsort(left, kind="stable"), np.argsort(right, kind="stable")
        assert np.allclose(np.sort(left), np.sort(right))
        assert np.allclose(a[order_l], b[order_r], rtol=1e-6, atol=1e-9), ch
        # and the channel does change with the drive (the check can fail)
        assert np.ptp(a) > 1e-5, ch
    toe = rec.outputs["toe_left"]
    assert toe[np.argmax(left)] < toe[0]  # own +M: toe-out


# ---------------------------------------------------------------- steering


def _steering_axis_rate(axle) -> np.ndarray:
    """First-order closed form d(toe)/ds [rad/m] (left, right) of rack travel ``s`` along +y.

    The knuckle turns by ``dtheta`` about the steering axis ``k`` (lower ball joint B to
    strut top T); the tie-rod outer point P moves by ``dtheta k x (P - B)``. The tie rod
    (unit vector ``e`` from the inner point to P) keeps its length:
    ``e . (dP - ds e_y) = 0``, so ``dtheta = ds e_y / (e . (k x (P - B)))``. The heading
    of the wheel turns by ``k_z dtheta`` about +z; toe-in is the heading turned inboard:
    ``d(toe) = -k_z dtheta`` on the left wheel, ``+k_z dtheta`` on the right.
    """
    p = axle.points
    B, T, P, Q = (
        p[k][0] for k in ("lower_ball_joint", "strut_top", "tie_rod_outer", "tie_rod_inner")
    )
    k = (T - B) / np.linalg.norm(T - B, axis=-1, keepdims=True)
    e = (P - Q) / np.linalg.norm(P - Q, axis=-1, keepdims=True)
    dtheta = e[:, 1] / np.einsum("si,si->s", e, np.cross(k, P - B))
    return np.array([-1.0, 1.0]) * k[:, 2] * dtheta


def test_steering_with_stiff_bushings_matches_the_ideal_joint_kinematics():
    # reference: CornerKinematics (independent minimal-coordinate solve with ideal
    # joints) with its tie-rod inner points moved by the rack travel along +y, at the
    # wheel-centre height the rig found; a rigid steering system (the kinematics has none)
    axle = build_axle(kinematic_like(reference_design())[None, :])
    axle.rack_compliance = np.zeros(1)
    res = run_tests(axle, ("steering",), steps=STEPS, keep_states=True)["steering"]
    assert res.ok.all(), res.messages
    kin = CornerKinematics(axle)
    tri0 = kin.TRI.copy()
    q = None
    for k, st in enumerate(res.states):
        s = res.grid[res.path[k]]
        kin.TRI = tri0 + s * np.array([0.0, 1.0, 0.0])
        q = kin.solve(st.r[:, :, 1, 2], q)
        _, Rk = kin._pose(q)
        rot_err = np.abs(log_so3(np.matmul(st.R[:, :, 1], np.swapaxes(Rk, -1, -2)))).max()
        pos_err = np.abs(kin.wc0 + q[..., :3] - st.r[:, :, 1]).max()
        assert rot_err < 2e-5, (k, rot_err)  # rad
        assert pos_err < 2e-6, (k, pos_err)  # m
    # the wheels did steer (several degrees at the ends)
    assert np.abs(res.channels["toe"][0]).max() > np.deg2rad(5.0)


def test_steering_rate_matches_the_tie_rod_closed_form_and_both_wheels_steer_alike(axle, runs):
    # reference: _steering_axis_rate (first order, rotation about the steering axis;
    # the small bump motion the rig adds and the bushings' give: 0.3 % on the reference car,
    # bound 2 %). Sign (golden): the reference car's tie rods lie behind the steering
    # axis (a trailing steering arm), so rack travel to the left (+y) steers both wheels
    # to the RIGHT: left wheel toe-in (toe grows), right wheel toe-out (toe falls)
    r = runs["steering"]
    i = r.static_index
    mid = r.mean_branch("toe")[0]  # (steps + 1, 2)
    slope = (mid[i + 1] - mid[i - 1]) / (r.grid[i + 1] - r.grid[i - 1])  # rad/m
    want = _steering_axis_rate(axle)
    assert np.allclose(slope, want, rtol=0.02), (slope, want)
    assert axle.points["tie_rod_outer"][0, 0, 0] < axle.points["lower_ball_joint"][0, 0, 0]
    assert want[0] > 0 > want[1] and slope[0] > 0 > slope[1]
    # both wheels steer the same way along the whole loop: the left toe rises where the
    # right toe falls
    d = np.diff(r.channels["toe"][0], axis=0)  # (P-1, 2)
    assert (np.sign(d[:, 0]) == -np.sign(d[:, 1])).all()
    assert (np.sign(d[:, 0]) == np.sign(np.diff(r.grid[r.path]))).all()


def test_steering_own_sense_gives_equal_left_and_right_toe(runs):
    # reference: mirror symmetry; the own drive (rack travel towards the wheel's outboard
    # side, measurements.knc.drive) puts both wheels' toe on one curve
    rec = to_recording(runs["steering"])
    assert rec.inputs["stroke"].max() == RACK_AMPLITUDE and not rec.inputs["pad_left"].any()
    left, right = drive(rec, "left"), drive(rec, "right")
    assert np.array_equal(right, -left) and mirrored(rec)
    a, b = rec.outputs["toe_left"], rec.outputs["toe_right"]
    assert np.allclose(
        a[np.argsort(left, kind="stable")], b[np.argsort(right, kind="stable")], atol=1e-9
    )
    back = from_recording(rec)
    assert back.unit == "m" and np.allclose(back.grid, runs["steering"].grid)


# ---------------------------------------------------------------- loops close


@pytest.mark.parametrize("test", NEW)
def test_each_new_loop_returns_to_its_start(axle, test):
    # reference: path independence of the plain (elastic) model: every step solved
    # afresh (reuse_revisits=False), the loop's last state (back at design after both
    # ends) equals its first to the solver tolerance (xtol 1e-6 m, rtol 1e-5 rad)
    r = run_tests(axle, (test,), steps=STEPS, reuse_revisits=False)[test]
    assert r.ok.all(), r.messages
    for ch, atol in (
        ("toe", 2e-5),
        ("camber", 2e-5),
        ("wheel_centre_z", 2e-6),
        ("contact_y", 2e-6),
    ):
        v = r.channels[ch][0]
        assert np.allclose(v[0], v[-1], rtol=0, atol=atol), (test, ch, v[0] - v[-1])
        assert np.ptp(v) > 10 * atol or ch != "toe", (test, ch)  # the loop did move


def test_steering_figure_is_drawn_against_the_rack_travel(runs, tmp_path, monkeypatch):
    # reference: the rig's own rack loop 0 -> +RACK_AMPLITUDE -> -RACK_AMPLITUDE -> 0
    # (its drive grid); wheel travel in this test is about 1 mm, the rack 30 mm
    import suspenv.reports.knc_rig as knc_rig

    drawn = []
    monkeypatch.setattr(knc_rig, "save_figure", lambda fig, path, **kw: drawn.append(fig))
    res = runs["steering"]
    knc_rig.plot_rig_curves(res, tmp_path / "steering.png", "steering")
    (fig,) = drawn
    rack_mm = res.grid[res.path] * 1e3
    assert rack_mm.max() == pytest.approx(RACK_AMPLITUDE * 1e3)
    assert rack_mm.min() == pytest.approx(-RACK_AMPLITUDE * 1e3)
    for ax in fig.axes:
        assert "rack travel" in ax.get_xlabel()
        for line in ax.get_lines():
            np.testing.assert_array_equal(line.get_xdata(), rack_mm)
