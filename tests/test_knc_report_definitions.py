"""Definitions and signs of the K&C report (suspenv.metrics.knc_report, docs/knc.md
"K&C report: definitions and signs") and of the full compliance matrix.

Each test names its independent reference: a geometry built to give an obvious answer,
the ideal-joint kinematics of ``CornerKinematics`` (a separate minimal-coordinate
solver), rigid-body motion of the solver's own states, loaded Newton solves of the
compliant axle (external loads through the same path as the rig's compliance tests),
closed forms, or mirror symmetry. Frames: ISO 8855 (x forward, y left, z up); outboard
is +y on the left wheel (0) and -y on the right wheel (1).
"""

from __future__ import annotations

import numpy as np
import pytest
from mcpherson_kinematics import CornerKinematics

from suspenv.metrics.knc import (
    FULL_COMPLIANCE_LOADS,
    FULL_COMPLIANCE_OUTPUTS,
    OBJECTIVE_NAMES,
    compliance_load,
    compliance_matrix,
    compliance_matrix_full,
    objectives,
)
from suspenv.metrics.knc_report import (
    ALL_ITEMS,
    ackermann_error_curve,
    carrier_patch_velocity,
    knc_report,
    patch_point,
    steer_angle,
    travel_report,
    usual_outputs,
    wheel_travel,
)
from suspenv.models.mcpherson import AxleSolver, build_axle, reference_design
from suspenv.models.mcpherson.params import BUSHINGS, PARAMETER_NAMES, SIDE_SIGN, AxleConstants
from suspenv.models.mcpherson.rotation import cross, rotate
from suspenv.rigs.knc import KCResult, loop_path, run_tests

IDX = {n: i for i, n in enumerate(PARAMETER_NAMES)}
DEG = np.rad2deg(1.0)


def kinematic_like(x: np.ndarray) -> np.ndarray:
    """Bushings stiff in translation (1e6 N/mm) and nearly free in rotation (1 N*mm/deg):
    the compliant axle then follows the ideal-joint kinematics."""
    x = x.copy()
    for b, comps in BUSHINGS.items():
        for c in comps:
            x[IDX[f"{b}_{c}"]] = 1e6 if c.startswith("k") else 1.0
    return x


@pytest.fixture(scope="module")
def axle():
    return build_axle(reference_design()[None, :])


@pytest.fixture(scope="module")
def ref(axle):
    res = run_tests(axle, ("parallel", "opposite", "single", "steering"), keep_states=True)
    assert all(r.ok.all() for r in res.values())
    return res


@pytest.fixture(scope="module")
def report(ref):
    return knc_report(ref)


@pytest.fixture(scope="module")
def tight(axle):
    """A tightly converged static state of the reference axle and its solver."""
    solver = AxleSolver(axle, xtol=1e-10, rtol=1e-9, ltol=1e-5)
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    assert conv.all()
    return solver, st


# ---------------------------------------------------------------- golden snapshot
#: the reference vehicle's report (left wheel), rig +-40 mm pad stroke, 30 steps;
#: a snapshot that guards against regressions (it does not show the numbers are right:
#: the other tests do). Regenerate with ``knc_report(run_tests(reference axle, ...))``.
GOLDEN = {
    "toe": -0.04075486,
    "camber": -0.5132572,
    "caster": 5.232453,
    "kpi": 14.21815,
    "scrub_radius": 7.146304,
    "trail": 34.0918,
    "bump_steer": -0.003216313,
    "camber_gain": -0.009027019,
    "caster_gain": 0.01425408,
    "track_change": 0.001531064,
    "wheel_recession": 0.03933682,
    "wheel_rate": 65.00295,
    "ride_rate": 51.66441,
    "spring_motion_ratio": 0.9609161,
    "damper_motion_ratio": 0.9609161,
    "roll_centre_height": 2.93642,
    "roll_centre_migration": -3.219042,
    "geometric_roll_centre_height": 3.281826,
    "anti_dive": 38.06041,
    "anti_lift": 18.59559,
    "roll_rate": 2164.224,
    "tramp_rate": 1505.999,
    "roll_steer": -0.03664285,
    "roll_camber": -0.120268,
    "arb_motion_ratio": -0.2854578,
    "steer_gradient": -0.4096139,
    "steer_ratio": 17.57753,
    "ackermann_error": -1.279441,
}


def test_golden_report_of_the_reference_vehicle(report):
    # reference: snapshot (regressions only), 7 significant figures; rtol 1e-4 because the
    # solver's tolerances (1e-6 m, 1e-5 rad) move the slopes by up to ~1e-5 of their value
    # with the batch's make-up (which tests run together)
    assert set(GOLDEN) <= set(report)
    bad = [
        f"{k}: {report[k][0, 0]:.9g} != golden {v:.9g}"
        for k, v in GOLDEN.items()
        if not abs(report[k][0, 0] - v) <= 1e-4 * abs(v)
    ]
    assert not bad, "\n".join(bad)
    assert set(report) == set(ALL_ITEMS)


def test_symmetric_axle_gives_equal_wheels_and_a_centred_roll_centre(report):
    # reference: mirror symmetry y -> -y of the reference (mirrored) axle
    for k, v in report.items():
        # to the solver's tolerances (1e-6 m, 1e-5 rad): 1e-4 of the value
        assert v[0, 0] == pytest.approx(v[0, 1], rel=1e-4, abs=1e-9), k
    assert abs(report["roll_centre_y_iso"][0, 0]) < 0.1  # mm, on the centreline


# ---------------------------------------------------------------- wheel-centre travel
def test_report_curves_are_against_wheel_centre_travel_not_pad_travel(ref, report):
    # reference: the raw channels. The abscissa is the wheel-centre height from static
    # (smaller than the pad stroke by the tyre's deflection); gradients against it equal
    # the paper's "suspension" objectives (also against wheel travel) and the ride rate is
    # the wheel rate times dz_w/dz_pad
    par = ref["parallel"]
    zw = wheel_travel(par, "down")
    raw = par.branch("wheel_centre_z", "down") - par.branch("wheel_centre_z", "down")[:, 15:16]
    assert np.allclose(zw, raw * 1e3)
    assert zw[0, -1, 0] < 0.85 * par.grid[-1] * 1e3  # the wheel moves less than the pad
    obj = dict(zip(OBJECTIVE_NAMES, objectives(ref)[0], strict=True))
    # tolerance: both are loop means of least-squares quadratic slopes of the same
    # samples on the same 7-point window, so they differ by the fits' round-off only:
    # the normal equations' condition number (~1e4 for 7 centred points) x eps (2.2e-16)
    # x |y| / (slope x spacing) (~6 for toe) ~ 1e-11 (7.7e-11 measured for bump steer);
    # rel 1e-9 bounds that for any BLAS kernel (the solver's own tolerance cancels)
    assert report["bump_steer"][0, 0] == pytest.approx(obj["par_toe"], rel=1e-9)
    assert report["camber_gain"][0, 0] == pytest.approx(obj["par_camber"], rel=1e-9)
    assert report["wheel_rate"][0, 0] == pytest.approx(obj["par_susp_ride_rate_pos"], rel=1e-9)
    # opposite travel against the roll angle: the paper's roll objectives (wheel mean)
    assert report["roll_rate"][0, 0] == pytest.approx(obj["opp_roll_rate_pos"], rel=1e-9)
    assert report["roll_steer"][0].mean() == pytest.approx(obj["opp_roll_toe"], rel=1e-9)
    assert report["roll_camber"][0].mean() == pytest.approx(obj["opp_roll_camber"], rel=1e-9)
    # chain rule: dF/dz_p = dF/dz_w * dz_w/dz_p, dz_w/dz_p = k_t / (k_w + k_t) (series)
    kt = AxleConstants().tyre_rate
    kw = report["wheel_rate"][0, 0]
    assert report["ride_rate"][0, 0] == pytest.approx(kw * kt / (kw + kt), rel=2e-3)


def test_cli_amplitude_is_the_pad_stroke_and_the_report_says_so(tmp_path, capsys):
    import argparse

    from suspenv.cli import knc

    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    knc.register(sub)
    help_text = sub.choices["knc"].format_help()
    assert "pad stroke" in help_text and "wheel-centre travel" in help_text
    args = parser.parse_args(["knc", "reference", "--steps", "10", "--out", str(tmp_path)])
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "pad stroke +-40 mm gave wheel-centre travel" in text
    line = next(x for x in text.splitlines() if x.strip().startswith("scrub_radius"))
    assert "(SAE)" in line and float(line.split()[1]) > 0  # inboard axis: positive


# ---------------------------------------------------------------- scrub radius, trail
@pytest.mark.parametrize("lbj_x_adams", [-15.4, 15.4])
def test_scrub_radius_and_trail_signs_on_an_obvious_geometry(lbj_x_adams):
    # reference: geometry by construction. A vertical steering axis through the lower ball
    # joint (strut top and strut axis point straight above it), camber and toe zero: the
    # axis meets the ground at the ball joint's (x, y). ADAMS x is rearward, so the joint
    # at ADAMS x = -15.4 mm lies 15.4 mm ahead of the wheel centre (trail +15.4 mm); it
    # lies 745 - 688.6 = 56.4 mm inboard of the wheel centre, below which the loaded
    # contact point lies (scrub radius +56.4 mm, SAE: axis inboard is positive)
    x = kinematic_like(reference_design())
    x[IDX["lower_ball_joint_x"]] = lbj_x_adams
    for p in ("strut_top", "strut_axis_point"):
        x[IDX[f"{p}_x"]] = lbj_x_adams
        x[IDX[f"{p}_y"]] = x[IDX["lower_ball_joint_y"]]
    x[IDX["static_camber"]] = 0.0
    x[IDX["static_toe"]] = 0.0
    axle = build_axle(x[None, :])
    res = run_tests(axle, ("parallel", "opposite"), steps=10)
    rep = travel_report(res)
    assert rep["caster"][0] == pytest.approx([0.0, 0.0], abs=0.05)
    assert rep["kpi"][0] == pytest.approx([0.0, 0.0], abs=0.05)
    assert rep["scrub_radius"][0] == pytest.approx([56.4, 56.4], abs=0.3)  # mm
    assert rep["trail"][0] == pytest.approx([-lbj_x_adams] * 2, abs=0.3)  # mm


def test_scrub_and_trail_are_taken_at_the_loaded_contact_point_on_the_pad_plane(ref, axle):
    # reference: the solver's states, constructed a second way: the steering axis
    # (ball joint -> top mount) meets the pad plane (solved as a 3x3 linear system with
    # the plane); the loaded contact point lies in the pad plane, in the wheel plane and
    # in the vertical plane through the spin axis, below the wheel centre
    par = ref["parallel"]
    solver = AxleSolver(axle)
    k = int(np.flatnonzero(par.path == par.static_index)[0])
    st = par.states[k]
    pad = par.channels["pad_z"][:, k]
    wc = st.r[:, :, 1]
    s = rotate(st.R[:, :, 1], solver.s0)
    P = patch_point(par, "down")[:, par.static_index]
    assert np.allclose(P[..., 2], pad, atol=1e-9)
    assert np.allclose(np.einsum("...i,...i", P - wc, s), 0.0, atol=1e-9)
    assert np.allclose(
        np.einsum("...i,...i", P - wc, cross(s, np.array([0, 0, 1.0]))), 0, atol=1e-9
    )
    assert (P[..., 2] < wc[..., 2]).all()
    pB = wc + rotate(st.R[:, :, 1], solver.kn_pts[:, :, 0])
    top = st.r[:, :, 2]
    for w in (0, 1):
        # pB + t (top - pB) = g, g_z = pad:  t = (pad - pB_z) / (top_z - pB_z)
        A = np.array([[1, 0, -(top - pB)[0, w, 0]], [0, 1, -(top - pB)[0, w, 1]], [0, 0, 1.0]])
        t = (pad[0, w] - pB[0, w, 2]) / (top - pB)[0, w, 2]
        gx, gy, _ = np.linalg.solve(A, [pB[0, w, 0], pB[0, w, 1], t])
        scrub = SIDE_SIGN[w] * (P[0, w, 1] - gy)  # inboard axis positive
        trail = gx - P[0, w, 0]
        assert par.channels["scrub_radius"][0, k, w] == pytest.approx(scrub, abs=1e-9)
        assert par.channels["trail"][0, k, w] == pytest.approx(trail, abs=1e-9)
    # the reference car: axis meets the ground inboard (SAE positive) and ahead
    assert (par.channels["scrub_radius"][0, k] > 0).all()
    assert (par.channels["trail"][0, k] > 0).all()


# ---------------------------------------------------------------- roll centre
def test_carrier_patch_velocity_is_the_rigid_motion_of_the_wheel_carrier(ref, axle):
    # reference: rigid-body motion of the solver's knuckle states: the knuckle point at
    # the static loaded contact point, carried by each state's (r, R), differenced
    # against the wheel-centre height (the report rebuilds it from channels only)
    par = ref["parallel"]
    i = par.static_index
    steps = par.grid.size - 1

    def pos(g: int) -> int:  # path position of grid point g on the descending branch
        return 2 * steps - steps // 2 - g

    assert par.path[pos(i)] == i and par.path[pos(i + 1)] == i + 1
    P, v = carrier_patch_velocity(par, "down")
    st0 = par.states[pos(i)]
    arm = np.einsum("nsji,nsj->nsi", st0.R[:, :, 1], P[:, i] - st0.r[:, :, 1])  # body frame
    ka, kb = pos(i - 1), pos(i + 1)
    pa = par.states[ka].r[:, :, 1] + np.einsum("nsij,nsj->nsi", par.states[ka].R[:, :, 1], arm)
    pb = par.states[kb].r[:, :, 1] + np.einsum("nsij,nsj->nsi", par.states[kb].R[:, :, 1], arm)
    za = par.states[ka].r[:, :, 1, 2]
    zb = par.states[kb].r[:, :, 1, 2]
    exact = (pb - pa) / (zb - za)[..., None]
    # second-order differences on the grid and small angles: 1e-4 m/m, against the
    # knuckle pitch's share of dx/dz (0.076 m/m on this car), which a wrong sign would show
    assert np.allclose(v[:, i], exact, atol=1e-4)
    assert np.allclose(v[:, i, :, 2], 1.0, atol=2e-3)


def test_roll_centre_height_matches_the_ideal_joint_kinematics(axle):
    # reference: CornerKinematics (ideal joints, its own minimal-coordinate solve) on an
    # axle with stiff bushings: the velocity of the knuckle point at the rig's static
    # loaded contact point P from the kinematic tangent; the front-view line through P
    # perpendicular to it meets the centreline at the roll centre, h above the pad plane
    x = kinematic_like(reference_design())
    kax = build_axle(x[None, :])
    res = run_tests(kax, ("parallel", "opposite"))
    rep = travel_report(res)
    par = res["parallel"]
    i = par.static_index
    P = 0.5 * (patch_point(par, "down") + patch_point(par, "up"))[:, i]
    z0 = par.mean_branch("wheel_centre_z")[:, i]
    kin = CornerKinematics(kax)
    q0 = kin.solve(z0)
    r0 = kin.wc0 + q0[..., :3]
    from suspenv.models.mcpherson.rotation import expm_so3

    R0 = expm_so3(q0[..., 3:])
    p_design = kin.wc0 + np.einsum("...ji,...j->...i", R0, P - r0)  # that point at design
    h = 1e-5
    v = (
        kin.point(kin.solve(z0 + h, q0), p_design) - kin.point(kin.solve(z0 - h, q0), p_design)
    ) / (2 * h)
    y_out = P[0, 0, 1]
    h_kin = y_out * v[0, 0, 1] / v[0, 0, 2] * 1e3  # mm above the pad plane (left wheel)
    assert rep["roll_centre_height"][0, 0] == pytest.approx(h_kin, abs=0.05)
    assert usual_outputs(res)["roll_centre_height"][0] == rep["roll_centre_height"][0, 0]


def test_roll_centre_moves_towards_the_rising_wheel_line_geometry(ref, report):
    # reference: closed form of two straight lines. The roll centre's lateral position in
    # opposite travel is where the two wheels' lines meet; re-intersecting the lines from
    # the report's own patch points and velocities by np.linalg.solve must give it
    from suspenv.metrics.knc_report import roll_centre_curve

    opp = ref["opposite"]
    P, v = carrier_patch_velocity(opp, "up")
    y, z = roll_centre_curve(opp, "up")
    for k in (opp.static_index - 3, opp.static_index + 3):
        nL = np.array([v[0, k, 0, 2], -v[0, k, 0, 1]])
        nR = np.array([v[0, k, 1, 2], -v[0, k, 1, 1]])
        ab = np.linalg.solve(np.column_stack([nL, -nR]), P[0, k, 1, 1:] - P[0, k, 0, 1:])
        yc, zc = P[0, k, 0, 1:] + ab[0] * nL
        assert y[0, k] == pytest.approx(yc * 1e3, rel=1e-9)
        ground = 0.5 * (P[0, k, 0, 2] + P[0, k, 1, 2])
        assert z[0, k] == pytest.approx((zc - ground) * 1e3, rel=1e-9, abs=1e-9)


# ---------------------------------------------------------------- anti-dive, anti-lift
def _dz_per_newton(solver, st, ext_unit, f=50.0):
    zs = []
    for sgn in (1.0, -1.0):
        s2, conv, _ = solver.solve(st, solver.pad_static, ext=sgn * f * ext_unit)
        assert conv.all()
        zs.append(s2.r[:, :, 1, 2])
    return (zs[0] - zs[1]) / (2 * f)


def test_anti_dive_and_anti_lift_match_loaded_solves(tight, ref, report):
    # reference: loaded Newton solves of the compliant axle (ADAMS's compliance-matrix
    # form): anti-dive = 100 b (L/h) (dz_w/dFx) / (dz_w/dFz), Fx a braking force at the
    # loaded contact point P (on both wheels), Fz the load transfer at P; anti-lift the
    # same with the tractive force at the wheel centre. The report takes the side-view
    # paths of parallel travel instead; for a linear elastic axle the two agree
    # (Maxwell-Betti reciprocity: dz/dFx = dx/dFz)
    solver, st = tight

    def at_P(col):  # the solver applies a contact-point load at P
        ext = np.zeros((1, 2, 9))
        ext[..., col] = 1.0
        return ext

    wc_x = np.zeros((1, 2, 9))
    wc_x[..., 6] = 1.0  # a force along +x at the wheel centre (the traction test's)
    dz_fx, dz_fz, dz_fx_wc = (_dz_per_newton(solver, st, e) for e in (at_P(0), at_P(2), wc_x))
    c = AxleConstants()
    lever = c.wheelbase / c.cg_height
    anti_dive = 100 * c.front_brake_share * lever * dz_fx / dz_fz
    anti_lift = 100 * c.front_drive_share * lever * dz_fx_wc / dz_fz
    assert report["anti_dive"][0] == pytest.approx(anti_dive[0], rel=5e-3)
    assert report["anti_lift"][0] == pytest.approx(anti_lift[0], rel=5e-3)
    # signs: the reference car's wheel centre and carrier patch point move forward in bump
    assert (report["anti_dive"] > 0).all() and (report["anti_lift"] > 0).all()


def test_anti_dive_scales_with_brake_share_and_wheelbase_over_cg_height(ref):
    # reference: the formula's closed form, 100 b (L/h) dx/dz: doubling L/h doubles it,
    # no front braking gives zero
    base = travel_report(ref, AxleConstants())
    long = travel_report(ref, AxleConstants(wheelbase=5200.0))
    none = travel_report(ref, AxleConstants(front_brake_share=0.0, front_drive_share=0.0))
    assert long["anti_dive"] == pytest.approx(2 * base["anti_dive"], rel=1e-12)
    assert long["anti_lift"] == pytest.approx(2 * base["anti_lift"], rel=1e-12)
    assert np.all(none["anti_dive"] == 0) and np.all(none["anti_lift"] == 0)


# ---------------------------------------------------------------- motion ratios
def test_spring_damper_and_anti_roll_bar_motion_ratios_match_the_kinematics():
    # reference: CornerKinematics (ideal joints) on a stiff-bushing axle: spring and strut
    # lengths of the kinematic knuckle pose differenced against the wheel-centre height;
    # the bar's angular ratio g = (drop-link point speed along the link) / (lever of the
    # bar end about the bar axis) from the bar geometry (as the anti-roll-bar share test)
    x = kinematic_like(reference_design())
    kax = build_axle(x[None, :])
    res = run_tests(kax, ("parallel", "opposite"))
    rep = travel_report(res)
    par = res["parallel"]
    z0 = par.mean_branch("wheel_centre_z")[:, par.static_index]
    kin = CornerKinematics(kax)
    p = kax.points
    q0 = kin.solve(z0)
    h = 1e-5

    def lengths(q):
        a = kin.direction(q, kin.a)  # strut axis (rod parallel to tube)
        upper = (
            kin.ST + a * np.linalg.norm(p["spring_upper_seat"] - p["strut_top"], axis=-1)[..., None]
        )
        spring = np.linalg.norm(kin.point(q, p["spring_lower_seat"]) - upper, axis=-1)
        strut = np.linalg.norm(kin.ST - kin.point(q, p["strut_axis_point"]), axis=-1)
        return spring, strut

    (sp_a, st_a), (sp_b, st_b) = lengths(kin.solve(z0 + h, q0)), lengths(kin.solve(z0 - h, q0))
    mr_spring = -(sp_a - sp_b) / (2 * h)
    mr_strut = -(st_a - st_b) / (2 * h)
    assert rep["spring_motion_ratio"][0] == pytest.approx(mr_spring[0], rel=2e-3)
    assert rep["damper_motion_ratio"][0] == pytest.approx(mr_strut[0], rel=2e-3)
    # bar: g [rad/m] from the geometry
    dq = kin.tangent(q0, z0)
    pD, E, C = p["drop_link_strut"], p["arb_drop_link"], p["arb_bush"]
    dlink = (pD - E) / np.linalg.norm(pD - E, axis=-1, keepdims=True)
    vD = (kin.point(q0 + 1e-6 * dq, pD) - kin.point(q0 - 1e-6 * dq, pD)) / 2e-6
    lever = np.einsum("...i,...i->...", np.cross([0.0, 1.0, 0.0], E - C), dlink)
    g = np.einsum("...i,...i->...", vD, dlink) / lever  # rad per m of wheel travel
    assert abs(rep["arb_motion_ratio"][0, 0]) == pytest.approx(abs(g[0, 0]) * DEG / 1e3, rel=0.02)


def test_damper_and_spring_ratios_differ_when_the_lower_seat_is_offset():
    # reference: geometry. With the lower seat on the strut axis both lengths change by
    # the rod's slide (equal ratios); a seat offset sideways makes the spring line lean
    # away from the strut axis, so its ratio changes and the strut's does not
    x = reference_design()[None, :]
    on_axis = travel_report(run_tests(build_axle(x), ("parallel", "opposite"), steps=10))
    c = AxleConstants(spring_lower_seat_offset=(0.0, 60.0, 0.0))
    off = travel_report(run_tests(build_axle(x, constants=c), ("parallel", "opposite"), steps=10))
    assert on_axis["spring_motion_ratio"] == pytest.approx(on_axis["damper_motion_ratio"], rel=1e-6)
    assert off["damper_motion_ratio"] == pytest.approx(on_axis["damper_motion_ratio"], rel=2e-3)
    assert abs(off["spring_motion_ratio"][0, 0] - off["damper_motion_ratio"][0, 0]) > 5e-3


# ---------------------------------------------------------------- compliance matrix
def test_compliance_matrix_matches_loaded_solves_column_by_column(axle, tight):
    # reference: finite differences (+-50 N or N*m) of tightly converged Newton solves
    # with the load applied on one wheel through the solver's external-load path (the
    # path of the rig's compliance tests), every output of both wheels: direct and
    # cross-wheel terms within 1e-3
    C, labels = compliance_matrix_full(axle)
    assert labels == {"outputs": FULL_COMPLIANCE_OUTPUTS, "loads": FULL_COMPLIANCE_LOADS}
    solver, st = tight
    pad = solver.pad_static
    scale = np.abs(C[0]).max(axis=(0, 2, 3))  # per output, for entries near zero
    for j in (0, 1):
        for k, load in enumerate(FULL_COMPLIANCE_LOADS):
            outs = []
            for f in (50.0, -50.0):
                s2, conv, _ = solver.solve(st, pad, ext=compliance_load(load, j)[None] * f)
                assert conv.all()
                outs.append(solver.outputs(s2, pad))
            for o, name in enumerate(FULL_COMPLIANCE_OUTPUTS):
                unit = DEG if name in ("toe", "camber") else 1e3
                mirror = SIDE_SIGN if name == "wheel_centre_y" else 1.0
                fd = (outs[0][name] - outs[1][name])[0] / 100.0 * unit * mirror * 1e3
                assert C[0, :, o, k, j] == pytest.approx(fd, rel=1e-3, abs=1e-4 * scale[o]), (
                    load,
                    j,
                    name,
                )


def test_compliance_matrix_signs_and_symmetry(axle):
    # reference: signs by definition and mirror symmetry of the mirrored axle. A toe-out
    # moment (Mz, the aligning test's own sense) turns the wheel toe-out; an upward force
    # lifts the wheel centre; an outboard force moves the wheel centre outboard; the
    # other wheel moves the same way under a vertical load only through the bar (smaller)
    C, _ = compliance_matrix_full(axle)
    o = {n: i for i, n in enumerate(FULL_COMPLIANCE_OUTPUTS)}
    k = {n: i for i, n in enumerate(FULL_COMPLIANCE_LOADS)}
    for w in (0, 1):
        assert C[0, w, o["toe"], k["Mz"], w] < 0  # toe-out moment -> toe-out
        assert C[0, w, o["wheel_centre_z"], k["Fz"], w] > 0  # up -> up
        assert C[0, w, o["wheel_centre_y"], k["Fy"], w] > 0  # outboard -> outboard
        assert C[0, w, o["wheel_centre_x"], k["Fx"], w] > 0  # forward -> forward
        other = 1 - w
        assert (
            0
            < C[0, other, o["wheel_centre_z"], k["Fz"], w]
            < 0.2 * C[0, w, o["wheel_centre_z"], k["Fz"], w]
        )
    # to the static solve's tolerances (1e-6 m, 1e-5 rad)
    assert np.allclose(C[0, 0, :, :, 0], C[0, 1, :, :, 1], rtol=1e-4, atol=1e-6)
    assert np.allclose(C[0, 1, :, :, 0], C[0, 0, :, :, 1], rtol=1e-4, atol=1e-6)
    # the direct 4 x 3 matrix is the full one's diagonal block (Mz toe column, left wheel)
    D, _ = compliance_matrix(axle)
    assert D[0, 0, 0, 2] == pytest.approx(C[0, 0, 0, 3, 0], rel=1e-12)


def test_mz_column_agrees_with_the_aligning_rig_test(axle, ref):
    # reference: the rig's aligning test (C1): +M about +z on both wheels, each wheel's own
    # sense toe-out positive; the left wheel's toe slope per kN*m equals the matrix's Mz
    # column (direct plus the right wheel's cross term, which the rig's two loads add)
    res = run_tests(axle, ("aligning",), steps=10)["aligning"]
    i = res.static_index
    mid = res.mean_branch("toe")[0, :, 0] * DEG
    slope = (mid[i + 1] - mid[i - 1]) / ((res.grid[i + 1] - res.grid[i - 1]) / 1e3)
    C, _ = compliance_matrix_full(axle)
    k = FULL_COMPLIANCE_LOADS.index("Mz")
    # the right wheel's +z moment is a toe-in moment in its own sense: -1 x its column
    expected = C[0, 0, 0, k, 0] - C[0, 0, 0, k, 1]
    assert slope == pytest.approx(expected, rel=0.02)
    assert slope < 0


# ---------------------------------------------------------------- steering
def test_steer_angle_sign_and_gradient_match_direct_rack_solves(axle, ref, report):
    # reference: direct Newton solves with the rack moved by +-0.5 mm (no loop); the
    # reference car's tie rods sit behind the wheel centre, so rack travel to the left
    # (+y) steers the wheels to the right: negative steer angle about +z
    solver = AxleSolver(axle, xtol=1e-10, rtol=1e-9, ltol=1e-5)
    pad = solver.pad_static
    st, _, _ = solver.solve(solver.initial_state(), pad)
    toes = []
    for q in (5e-4, -5e-4):
        s2, conv, _ = solver.solve(st, pad, rack=np.full((1, 2), q))
        assert conv.all()
        toes.append(solver.outputs(s2, pad)["toe"][0] * DEG)
    dtoe = (toes[0] - toes[1]) / 1.0  # deg per mm of rack
    delta = -SIDE_SIGN * dtoe  # steer angle about +z
    assert report["steer_gradient"][0] == pytest.approx(delta, rel=0.02)
    assert (report["steer_gradient"][0] < 0).all()
    sa = steer_angle(ref["steering"], "down")
    assert (sa[0, -1] < 0).all() and (sa[0, 0] > 0).all()  # +y rack end: right turn


def test_steer_ratio_is_the_steering_wheel_angle_over_the_mean_road_wheel_angle(ref, report):
    # reference: closed form: 360 deg per rack_travel_per_rev mm of rack, over the mean
    # road-wheel angle per mm of rack
    c = AxleConstants()
    mean_grad = abs(report["steer_gradient"][0].mean())
    assert report["steer_ratio"][0, 0] == pytest.approx(360.0 / c.rack_travel_per_rev / mean_grad)
    half = knc_report(ref, AxleConstants(rack_travel_per_rev=25.0))
    assert half["steer_ratio"][0, 0] == pytest.approx(2 * report["steer_ratio"][0, 0])


def _fake_steering(delta_left: np.ndarray, delta_right: np.ndarray) -> KCResult:
    """A steering KCResult whose toe channels give the road-wheel angles [deg] on the grid."""
    steps = delta_left.size - 1
    path = loop_path(steps)
    toe = np.stack([-SIDE_SIGN[0] * delta_left, -SIDE_SIGN[1] * delta_right], axis=-1)[path]
    grid = np.linspace(-0.03, 0.03, steps + 1)
    return KCResult("steering", grid, path, {"toe": np.deg2rad(toe)[None]}, np.ones(1, bool), [""])


def test_ackermann_error_closed_forms():
    # reference: closed forms. Parallel steer (both wheels at the same angle d) misses
    # Ackermann by d - atan(L tan d / (L - t tan d)) (negative: the inner wheel steers too
    # little); wheels set to the exact Ackermann pair give zero in both turn directions
    L, t = 2600.0, 1400.0
    d = np.linspace(-20.0, 20.0, 11)
    res = _fake_steering(d, d)
    err = ackermann_error_curve(res, "down", L, np.array([t]))[0]
    ad = np.abs(np.deg2rad(d))
    want = np.abs(d) - np.rad2deg(np.arctan(L * np.tan(ad) / (L - t * np.tan(ad))))
    assert np.allclose(err, want, atol=1e-9) and (err[d != 0] < 0).all()
    # exact Ackermann: outer angle d_o, inner atan(L tan d_o / (L - t tan d_o))
    do = np.deg2rad(np.linspace(0.0, 15.0, 6))
    di = np.rad2deg(np.arctan(L * np.tan(do) / (L - t * np.tan(do))))
    do = np.rad2deg(do)
    pair = _fake_steering(np.r_[-do[::-1], di[1:]], np.r_[-di[::-1], do[1:]])
    err = ackermann_error_curve(pair, "down", L, np.array([t]))[0]
    assert np.allclose(err, 0.0, atol=1e-9)


def test_a_measurement_without_pitch_and_strut_length_keeps_the_front_view(ref, report):
    # reference: the full report of the same loops. Without the knuckle pitch the
    # carrier's rotation about its spin axis is unknown: that moves the patch point
    # along x only, so the roll centre (front view) stays within 0.05 mm, while the
    # anti-dive (side view) and the damper ratio are not reported (NaN) rather than wrong
    import dataclasses

    drop = ("knuckle_pitch", "strut_length")
    cut = {
        t: dataclasses.replace(r, channels={k: v for k, v in r.channels.items() if k not in drop})
        for t, r in ref.items()
    }
    rep = knc_report(cut)
    assert np.isnan(rep["anti_dive"]).all() and np.isnan(rep["damper_motion_ratio"]).all()
    assert rep["roll_centre_height"] == pytest.approx(report["roll_centre_height"], abs=0.05)
    assert rep["anti_lift"] == pytest.approx(report["anti_lift"], rel=1e-12)
    with pytest.raises(Exception, match="no `knuckle_pitch` channel"):
        carrier_patch_velocity(cut["parallel"], "down")


def test_steering_curves_give_toe_left_and_right_against_rack_travel(ref):
    # reference: the raw toe channels; a symmetric axle steers mirror-symmetrically: the
    # left wheel at +s is the right wheel at -s (steer angles of opposite sign)
    from suspenv.metrics.knc_report import steering_curves

    cur = steering_curves(ref["steering"])
    res = ref["steering"]
    assert np.allclose(cur["rack"], res.grid * 1e3)
    assert np.allclose(cur["toe"], res.mean_branch("toe") * DEG)
    sa = cur["steer_angle"][0]
    assert np.allclose(sa[:, 0], -sa[::-1, 1], atol=1e-6)
    assert cur["ackermann_error"][0, res.static_index] == 0.0
