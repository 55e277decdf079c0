"""McPherson K&C solver: equilibrium, kinematics, symmetry, hand calculations, signs."""

from __future__ import annotations

import dataclasses

import mcpherson_reference as reference
import numpy as np
import pytest
from knc_checks import XTOL, channel_tolerance
from mcpherson_kinematics import CornerKinematics
from scipy.spatial.transform import Rotation

from suspenv.core.errors import ValidationError
from suspenv.metrics.knc import objectives_subset, quadratic_fit
from suspenv.models.mcpherson import (
    AxleSolver,
    build_axle,
    design_space,
    reference_design,
)
from suspenv.models.mcpherson.params import BUSHINGS, PARAMETER_NAMES, SIDE_SIGN
from suspenv.models.mcpherson.rotation import expm_so3, log_so3
from suspenv.rigs.knc import run_tests

IDX = {n: i for i, n in enumerate(PARAMETER_NAMES)}


@pytest.fixture(scope="module")
def reference_runs():
    """Reference vehicle and a random in-range design, all three tests, states kept."""
    X = np.vstack([reference_design(), design_space().to_physical(np.full((1, 49), 0.3))])
    axle = build_axle(X)
    return axle, run_tests(axle, steps=10, keep_states=True)


def kinematic_like(x: np.ndarray) -> np.ndarray:
    """Bushings stiff in translation (1e6 N/mm) and nearly free in rotation (1 N*mm/deg)."""
    x = x.copy()
    for b, comps in BUSHINGS.items():
        for c in comps:
            x[IDX[f"{b}_{c}"]] = 1e6 if c.startswith("k") else 1.0
    return x


def test_rotation_helpers_match_scipy():
    # reference: scipy.spatial.transform.Rotation (independent implementation)
    w = np.random.default_rng(1).normal(size=(40, 3)) * 0.8
    assert np.allclose(expm_so3(w), Rotation.from_rotvec(w).as_matrix(), atol=1e-14)
    assert np.allclose(log_so3(Rotation.from_rotvec(w).as_matrix()), w, atol=1e-12)


def test_every_body_is_in_force_and_moment_balance(reference_runs):
    # reference: statics of each rigid body, sum F = 0 and sum (p x F + M) = 0 about the
    # global origin, from the element loads re-evaluated at every converged step
    axle, results = reference_runs
    solver = AxleSolver(axle)
    for test, res in results.items():
        assert res.ok.all(), res.messages
        pad0 = solver.pad_static
        sign = {"parallel": (1, 1), "opposite": (1, -1), "single": (1, 0)}[test]
        for k, st in enumerate(res.states):
            pad = pad0 + np.array(sign) * res.grid[res.path[k]]
            F, M = reference.body_loads(solver, st, pad)
            assert np.abs(F).max() < 0.05, (test, k, np.abs(F).max())  # N, loads are kN
            assert np.abs(M).max() < 0.05, (test, k, np.abs(M).max())  # N*m


def test_joints_hold_exactly(reference_runs):
    # reference: the ball joint is one point of two bodies; tie rod and drop link keep
    # their design lengths (exact constraints, no penalty gap); the tie rods' inner
    # ends sit on the rack, which the steering system lets move by C F along y (F the
    # tie rods' net force, from the multipliers: AxleSolver.rack_force)
    axle, results = reference_runs
    s = AxleSolver(axle)
    p = axle.points
    for res in results.values():
        for st in res.states:
            R, r = st.R, st.r
            b_arm = r[:, :, 0] + np.einsum("nsij,nsj->nsi", R[:, :, 0], s.lca_pts[:, :, 2])
            b_kn = r[:, :, 1] + np.einsum("nsij,nsj->nsi", R[:, :, 1], s.kn_pts[:, :, 0])
            assert np.abs(b_arm - b_kn).max() < 1e-7
            tro = r[:, :, 1] + np.einsum("nsij,nsj->nsi", R[:, :, 1], s.kn_pts[:, :, 1])
            shift = s.C_rack * s.rack_force(st)  # (n,) m along +y
            tri = p["tie_rod_inner"] + shift[:, None, None] * np.array([0.0, 1.0, 0.0])
            L = np.linalg.norm(tro - tri, axis=-1)
            assert np.allclose(L, s.L_tie, atol=1e-7)


def test_stiff_bushings_reproduce_the_pure_kinematic_solution():
    # reference: CornerKinematics, an independent minimal-coordinate solve with ideal
    # joints (lower arm revolute about the bush axis, spherical top mount)
    x = kinematic_like(reference_design())
    axle = build_axle(x[None, :])
    res = run_tests(axle, tests=("parallel",), steps=8, keep_states=True)["parallel"]
    assert res.ok.all()
    kin = CornerKinematics(axle)
    q = None
    for k, st in enumerate(res.states):
        z = st.r[:, :, 1, 2]
        q = kin.solve(z, q)
        _, Rk = kin._pose(q)
        rot_err = np.abs(log_so3(np.matmul(st.R[:, :, 1], np.swapaxes(Rk, -1, -2)))).max()
        pos_err = np.abs(kin.wc0 + q[..., :3] - st.r[:, :, 1]).max()
        assert rot_err < 2e-5, (k, rot_err)  # rad
        assert pos_err < 2e-6, (k, pos_err)  # m


def test_mirrored_axle_gives_mirrored_and_antisymmetric_results(reference_runs):
    # reference: mirror symmetry about the x-z plane
    _, results = reference_runs
    par, opp = results["parallel"], results["opposite"]
    # tolerance: each side is converged to the solver's tolerances on its own round-off,
    # so the sides may differ by twice those (knc_checks.channel_tolerance); a mirror
    # error is millimetres
    for name in ("toe", "camber", "caster", "tyre_fz", "wheel_centre_z", "wheel_centre_x"):
        tol = 2 * channel_tolerance(name)
        ch = par.channels[name]
        assert np.allclose(ch[..., 0], ch[..., 1], rtol=0, atol=tol), name
        # opposite travel: the left wheel at +s is the right wheel at -s
        for br in ("down", "up"):
            b = opp.branch(name, br)
            assert np.allclose(b[:, :, 0], b[:, ::-1, 1], rtol=0, atol=tol), name
    y = par.channels["wheel_centre_y"]
    assert np.allclose(y[..., 0], -y[..., 1], rtol=0, atol=2 * XTOL)
    # antisymmetric axle quantities vanish at static and are odd in the stroke (to the
    # solver tolerance: each of the four tyre forces within the tyre rate x 1e-6 m, about
    # 0.25 N, of its exact value; the roll force at 40 mm is hundreds of N)
    axle, _ = reference_runs
    tol = 4 * float(axle.tyre_rate.max()) * XTOL
    fz = opp.branch("tyre_fz", "down")
    dF = fz[..., 0] - fz[..., 1]
    assert np.allclose(dF, -dF[:, ::-1], rtol=0, atol=tol)
    assert np.abs(dF[:, opp.static_index]).max() < tol


def test_plain_model_loop_closes(reference_runs):
    # reference: without path-dependent effects both branches must coincide
    _, results = reference_runs
    for res in results.values():
        for name in ("toe", "tyre_fz", "camber"):
            assert np.allclose(res.branch(name, "down"), res.branch(name, "up"), atol=1e-6)


def test_ride_rate_is_wheel_rate_in_series_with_the_tyre(reference_runs):
    # reference: hand calculation, springs in series: 1/k_ride = 1/k_wheel + 1/k_tyre
    axle, results = reference_runs
    F = objectives_subset(results, ("par_susp_ride_rate_pos",))[:, 0]
    par = results["parallel"]
    c = par.static_index
    ride = np.mean(
        [
            quadratic_fit(
                par.branch("pad_z", b)[..., 0] * 1e3, par.branch("tyre_fz", b)[..., 0], c
            )[1]
            for b in ("down", "up")
        ],
        axis=0,
    )
    kt = axle.tyre_rate[:, 0] / 1e3
    assert np.allclose(ride, 1.0 / (1.0 / F + 1.0 / kt), rtol=5e-3)


def test_wheel_rate_of_a_kinematic_axle_matches_the_hand_calculation():
    # reference: hand calculation by virtual work on the ideal-joint linkage,
    # k_wheel = k_spring MR^2 + F_spring dMR/dz (MR = -dL/dz of the spring length along
    # the wheel-centre travel, from the independent CornerKinematics solve)
    x = kinematic_like(reference_design())
    axle = build_axle(x[None, :])
    res = run_tests(axle, tests=("parallel",), steps=8)
    wheel = objectives_subset(res, ("par_susp_ride_rate_pos",))[0, 0]
    kin = CornerKinematics(axle)
    z0 = axle.points["wheel_centre"][..., 2]
    d_up = np.linalg.norm(axle.points["spring_upper_seat"] - kin.ST, axis=-1, keepdims=True)

    def length(z):
        q = kin.solve(z0 + z)
        pu = kin.ST + kin.direction(q, kin.a) * d_up
        return np.linalg.norm(kin.point(q, axle.points["spring_lower_seat"]) - pu, axis=-1)

    h = 1e-4
    mr = lambda z: -(length(z + h) - length(z - h)) / (2 * h)  # noqa: E731
    z_static = (res["parallel"].branch("wheel_centre_z", "down")[0, 4] - z0[0])[0]
    H = 2e-3
    MR = mr(z_static)[0, 0]
    dMR = ((mr(z_static + H) - mr(z_static - H)) / (2 * H))[0, 0]
    F = res["parallel"].branch("spring_force", "down")[0, 4, 0]
    hand = (axle.constants.spring_rate * 1e3 * MR**2 + F * dMR) / 1e3  # N/mm
    assert wheel == pytest.approx(hand, rel=0.02)


def test_anti_roll_bar_share_single_versus_parallel_and_opposite():
    # reference: hand calculation of a torsion bar of stiffness k driven by two drop
    # links: per-wheel rate share 2 k g^2 in opposite travel (twist = 2 g z) and, in
    # single travel, k g^2 in series with the other wheel's support k_o (its suspension
    # and its tyre in parallel between the fixed body and the fixed pad, k_o = k_w + k_t):
    # share_single = k g^2 k_o / (k g^2 + k_o)
    x = kinematic_like(reference_design())
    axle = build_axle(x[None, :])
    res = run_tests(axle, steps=10)
    par, opp, sgl = objectives_subset(
        res, ("par_susp_ride_rate_pos", "opp_roll_force_pos", "sgl_susp_ride_rate_pos")
    )[0]
    share_opp = opp - par
    assert share_opp > 0
    kg2 = share_opp / 2.0  # k g^2 [N/mm] from the opposite test
    kt = axle.constants.tyre_rate
    k_o = par + kt
    hand_single = kg2 * k_o / (kg2 + k_o)
    assert sgl - par == pytest.approx(hand_single, rel=0.03)


def test_anti_roll_bar_share_against_its_geometry():
    # reference: hand calculation from the bar's geometry: g = (drop-link point speed
    # along the link) / (lever arm of the bar end about the bar axis along the link),
    # share = 2 k g^2 (k the torsional stiffness), drop-link speed from CornerKinematics
    x = kinematic_like(reference_design())
    axle = build_axle(x[None, :])
    res = run_tests(axle, tests=("parallel", "opposite"), steps=10)
    par, opp = objectives_subset(res, ("par_susp_ride_rate_pos", "opp_roll_force_pos"))[0]
    kin = CornerKinematics(axle)
    z0 = axle.points["wheel_centre"][..., 2]
    q0 = kin.solve(z0)
    dq = kin.tangent(q0, z0)
    h = 1e-6
    pD = axle.points["drop_link_strut"]
    E = axle.points["arb_drop_link"]
    d = (pD - E) / np.linalg.norm(pD - E, axis=-1, keepdims=True)
    vD = (kin.point(q0 + h * dq, pD) - kin.point(q0 - h * dq, pD)) / (2 * h)
    C = axle.points["arb_bush"]
    arm = np.einsum("...i,...i->...", np.cross([0.0, 1.0, 0.0], E - C), d)
    g = np.einsum("...i,...i->...", vD, d) / arm  # rad per m of wheel travel
    k = axle.arb_torsion[0]
    hand = 2 * k * g[0, 0] ** 2 / 1e3  # N/mm
    assert opp - par == pytest.approx(hand, rel=0.05)


def test_signs_of_camber_toe_caster_on_an_obvious_geometry():
    # reference: geometry by construction. Static camber -1 deg must put the top of the
    # left wheel inboard; toe +0.5 deg (toe-in) must put the wheel's front inboard of its
    # rear; the strut top rearward of the ball joint gives positive caster; inboard gives
    # positive kingpin inclination.
    x = kinematic_like(reference_design())
    x[IDX["static_camber"]] = -1.0
    x[IDX["static_toe"]] = 0.5
    axle = build_axle(x[None, :])
    solver = AxleSolver(axle)
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    assert conv.all()
    out = solver.outputs(st, solver.pad_static)
    assert np.rad2deg(out["camber"]) == pytest.approx(-1.0, abs=0.01)
    assert np.rad2deg(out["toe"]) == pytest.approx(0.5, abs=0.01)
    # geometric construction of the wheel's top and front points (both wheels)
    s = np.einsum("nsij,nsj->nsi", st.R[:, :, 1], solver.s0)
    wc = st.r[:, :, 1]
    up = np.cross(s, np.cross([0.0, 0.0, 1.0], s))  # in-plane upward direction
    top = wc + 0.277 * up / np.linalg.norm(up, axis=-1, keepdims=True)
    assert (SIDE_SIGN * (top[..., 1] - wc[..., 1]) < 0).all()  # top inboard
    fwd = np.cross(s, [0.0, 0.0, 1.0]) * SIDE_SIGN[:, None]
    front = wc + 0.277 * fwd / np.linalg.norm(fwd, axis=-1, keepdims=True)
    rear = wc - 0.277 * fwd / np.linalg.norm(fwd, axis=-1, keepdims=True)
    assert (SIDE_SIGN * (front[..., 1] - rear[..., 1]) < 0).all()  # toe-in
    p = axle.points
    top_rear = p["strut_top"][..., 0] < p["lower_ball_joint"][..., 0]  # ISO x forward
    assert top_rear.all() and (out["caster"] > 0).all()
    inboard = SIDE_SIGN * (p["strut_top"][..., 1] - p["lower_ball_joint"][..., 1]) < 0
    assert inboard.all() and (out["kpi"] > 0).all()


def test_compliance_from_the_jacobian_equals_finite_differences_of_loaded_solves():
    # reference: finite differences of full Newton solves (tight tolerances) with +-50 N
    # (N*m) loads at the contact patches against the linearised compliance matrix
    from suspenv.metrics.knc import COMPLIANCE_LOADS, COMPLIANCE_OUTPUTS, compliance_matrix

    axle = build_axle(reference_design()[None, :])
    C, labels = compliance_matrix(axle)
    assert labels == {"outputs": COMPLIANCE_OUTPUTS, "loads": COMPLIANCE_LOADS}
    solver = AxleSolver(axle, xtol=1e-10, rtol=1e-9, ltol=1e-5)
    st, _, _ = solver.solve(solver.initial_state(), solver.pad_static)
    scale = {"toe": np.rad2deg(1.0), "camber": np.rad2deg(1.0)}
    for j, load in enumerate(COMPLIANCE_LOADS):
        outs = []
        for f in (50.0, -50.0):
            ext = np.zeros((1, 2, 6))
            col = {"Fx": 0, "Fy": 1, "Mz": 5}[load]
            sign = {"Fx": 1.0, "Fy": 1.0, "Mz": 1.0}[load]  # left: outboard +y, toe-out +z
            ext[:, 0, col] = f * sign  # the load acts on the left wheel only
            s2, conv, _ = solver.solve(st, solver.pad_static, ext=ext)
            assert conv.all()
            outs.append(solver.outputs(s2, solver.pad_static))
        for i, name in enumerate(COMPLIANCE_OUTPUTS):
            mirror = SIDE_SIGN[0] if name == "wheel_centre_y" else 1.0
            k = scale.get(name, 1e3) * mirror
            fd = (outs[0][name] - outs[1][name])[0, 0] / 100.0 * k * 1e3  # per kN (kN*m)
            assert C[0, 0, i, j] == pytest.approx(fd, rel=0.02, abs=1e-4), (load, name)
    # a symmetric axle has equal wheels; rtol 1e-5: the Jacobian's columns move both
    # knuckles at once, so the compliant rack's cross-side coupling through them (about
    # 1e-4 of those entries, ~C k with C the rack compliance and k a tie rod's force per
    # length) is lumped into each side's own column, which breaks the mirror symmetry of
    # the linearisation by ~1e-6 of its values
    assert np.allclose(C[:, 0], C[:, 1], rtol=1e-5, atol=1e-6)


def test_balance_holds_with_hysteresis_and_friction():
    # reference: statics about the global origin, with the path-dependent elements on
    from suspenv.models.mcpherson import axle_effect

    eff = [
        axle_effect("dahl_hysteresis", "lower_arm_and_top_mount", f_c=60.0),
        axle_effect("coulomb_friction", "strut", f_c=80.0),
    ]
    axle = build_axle(reference_design()[None, :])
    res = run_tests(axle, tests=("single",), steps=6, effects=eff, keep_states=True)["single"]
    assert res.ok.all()
    solver = AxleSolver(axle, eff)
    for k, st in enumerate(res.states):
        pad = solver.pad_static + np.array([1.0, 0.0]) * res.grid[res.path[k]]
        prev = res.states[k - 1] if k else st  # the committed history of the step
        hist = dataclasses.replace(st, hyst=prev.hyst, fric=prev.fric)
        F, M = reference.body_loads(solver, st, pad, history=hist)
        # bound: the Dahl elements are stiff over their micrometre-scale reversals, so the
        # step tolerance (1e-7 m with effects) leaves up to ~0.1 N; 0.5 N is 0.015 % of
        # the wheel load
        assert np.abs(F).max() < 0.5 and np.abs(M).max() < 0.5, k


def test_build_axle_rejects_wrong_shapes():
    with pytest.raises(ValidationError, match=r"shape \(n, 49\)"):
        build_axle(np.zeros((2, 48)))


def test_effects_are_off_by_default_and_validated():
    from suspenv.models.mcpherson import axle_effect, bushings_at

    axle = build_axle(reference_design()[None, :])
    assert AxleSolver(axle).effects == ()
    with pytest.raises(ValidationError, match="must be a bushing"):
        axle_effect("dahl_hysteresis", "nope")
    assert bushings_at("lower_arm") == ("lca_front", "lca_rear")
    # a zero friction level is no friction (no path state)
    off = AxleSolver(axle, [axle_effect("coulomb_friction", "strut", f_c=0.0)])
    assert off.initial_state().fric is None
