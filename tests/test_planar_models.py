"""Planar linkage physics: closed forms, invariants, and the two solvers checking each other.

Stated tolerance of analytic vs pymunk over +-60 mm (25 points), every bundled geometry:
camber 1e-4 deg, half-track change 1e-3 mm, contact height 1e-6 m, roll-centre height
0.3 mm (pymunk's comes from finite differences along 5 mm steps), motion ratio 1e-3,
wheel load 0.05 N, wheel rate 0.1 N/mm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from suspenv.core.errors import LockupError, ValidationError
from suspenv.models.planar import (
    bundled_geometries,
    geometry_from_dict,
    geometry_to_toml,
    load_geometry,
    solve_single,
    solve_sweep,
    sweep_outputs,
)
from suspenv.models.planar.geometry import DoubleWishbone, stack_geometries
from suspenv.models.planar.pymunk_model import simulate_sweep

TRAVEL = np.linspace(-0.06, 0.06, 25)
ALL = bundled_geometries()
WISHBONES = [n for n in ALL if load_geometry(n).kind == "double_wishbone"]
STRUTS = [n for n in ALL if load_geometry(n).kind == "mcpherson"]


def test_bundled_examples_cover_both_kinds():
    assert "parallel_equal_arms" in WISHBONES and len(WISHBONES) >= 2
    assert len(STRUTS) >= 2


# ----------------------------------------------------------- closed forms
def test_parallel_equal_arms_closed_form():
    # closed form for a parallelogram: the upright translates without rotating, every
    # upright point moves on a circle of the arm length L about a centre L inboard:
    # z - z0 = L sin(psi), y - y0 = L (cos(psi) - 1); camber stays static; the contact
    # point moves along (cos, -sin)... so dy/dz = -tan(psi) and the roll centre (line
    # through the contact point parallel to the arms) is z_c - y_c tan(psi).
    g = load_geometry("parallel_equal_arms")
    L = float(np.linalg.norm(g.lower_outer - g.lower_inner))
    out = sweep_outputs(g, solve_single(g, TRAVEL))
    psi = np.arcsin(TRAVEL / L)
    y0 = float(g.contact_point[0])
    np.testing.assert_allclose(out.camber_deg, math.degrees(float(g.static_camber)), atol=1e-9)
    np.testing.assert_allclose(out.half_track_mm, 1e3 * L * (np.cos(psi) - 1), atol=1e-7)
    y_c = y0 + L * (np.cos(psi) - 1)
    np.testing.assert_allclose(out.roll_centre_mm, 1e3 * (TRAVEL - y_c * np.tan(psi)), atol=1e-5)
    # motion ratio: the spring's arm point rotates by psi about the lower inner pivot
    r = g.spring_arm - g.lower_inner
    s_pt = (
        g.lower_inner
        + np.c_[np.cos(psi) * r[0] - np.sin(psi) * r[1], np.sin(psi) * r[0] + np.cos(psi) * r[1]]
    )
    v = np.c_[-np.sin(psi) * r[0] - np.cos(psi) * r[1], np.cos(psi) * r[0] - np.sin(psi) * r[1]]
    d = s_pt - g.spring_body
    dl_dpsi = np.sum(d * v, axis=1) / np.linalg.norm(d, axis=1)
    np.testing.assert_allclose(out.motion_ratio, -dl_dpsi / (L * np.cos(psi)), rtol=1e-7)
    assert float(out.camber_gain_deg_per_m) == pytest.approx(0.0, abs=1e-9)


def _intersect(p1, p2, p3, p4):
    """Intersection of line p1-p2 with line p3-p4 by a 2x2 solve (one point at a time)."""
    A = np.array([p2 - p1, -(p4 - p3)]).T
    t = np.linalg.solve(A, p3 - p1)
    return p1 + t[0] * (p2 - p1)


@pytest.mark.parametrize("name", [n for n in WISHBONES if n != "parallel_equal_arms"])
def test_double_wishbone_roll_centre_and_camber_gain_from_instant_centre(name):
    # reference: the textbook instant-centre construction (rigid links), solved here
    # point by point with a 2x2 linear solve: IC = wishbone lines' intersection;
    # RC = line contact->IC at y = 0; camber gain = -1/(y_contact - y_IC) rad/m
    # (the upright turns about the IC while the contact point moves vertically).
    g = load_geometry(name)
    sweep = solve_single(g, TRAVEL)
    out = sweep_outputs(g, sweep)
    p = sweep.points
    z0 = float(g.contact_point[1])
    for i in range(TRAVEL.size):
        ic = _intersect(
            p["lower_inner"][i], p["lower_outer"][i], p["upper_inner"][i], p["upper_outer"][i]
        )
        c = p["contact"][i]
        rc = c + (ic - c) * (0.0 - c[0]) / (ic[0] - c[0])
        assert out.roll_centre_mm[i] == pytest.approx(1e3 * (rc[1] - z0), abs=1e-4)
        if i == TRAVEL.size // 2:
            gain = -math.degrees(1.0 / (c[0] - ic[0]))
            assert float(out.camber_gain_deg_per_m) == pytest.approx(gain, rel=1e-6)


def test_camber_sign_convention_sla_gains_negative_camber_in_bump():
    # a short upper arm whose line meets the lower arm's line inboard pulls the top of
    # the wheel towards the body in bump: camber must become more negative.
    g = load_geometry("double_wishbone")
    out = sweep_outputs(g, solve_single(g, TRAVEL))
    assert out.camber_deg[-1] < out.camber_deg[TRAVEL.size // 2] < 0
    assert float(out.camber_gain_deg_per_m) < 0


@pytest.mark.parametrize("name", ALL)
def test_wheel_load_does_the_spring_work(name):
    # energy balance (rigid, frictionless, no gravity): the work of the pad force over
    # the travel equals the spring energy change F0*dc + k*dc^2/2 (dc = compression).
    g = load_geometry(name)
    s = np.linspace(-0.06, 0.06, 601)
    sweep = solve_single(g, s)
    out = sweep_outputs(g, sweep)
    dc = sweep.spring_length[0] - sweep.spring_length[-1]
    k, f0 = float(g.spring_rate), float(g.spring_preload)
    l0 = sweep.spring_length[300]
    c0, c1 = l0 - sweep.spring_length[0], l0 - sweep.spring_length[-1]
    energy = f0 * dc + 0.5 * k * (c1**2 - c0**2)
    assert np.trapezoid(out.wheel_load_N, s) == pytest.approx(energy, rel=1e-5)
    # and the wheel rate is the slope of that load (second-order differences)
    np.testing.assert_allclose(
        out.wheel_rate_N_per_mm[1:-1],
        1e-3 * np.gradient(out.wheel_load_N, s)[1:-1],
        rtol=1e-4,
    )


@pytest.mark.parametrize("name", ALL)
def test_analytic_pose_keeps_links_rigid_and_the_pad_height(name):
    g = load_geometry(name)
    sweep = solve_single(g, TRAVEL)
    # every named point at the design position, plus the contact point (..., 2) m
    d = {n: getattr(g, n) for n in g.point_names} | {"contact": g.contact_point}
    p = sweep.points

    def dist(a, b, pts):
        return np.linalg.norm(np.asarray(pts[a]) - np.asarray(pts[b]), axis=-1)

    pairs = [
        ("lower_inner", "lower_outer"),
        ("lower_outer", "wheel_centre"),
        ("lower_outer", "contact"),
        ("wheel_centre", "contact"),
    ]
    if isinstance(g, DoubleWishbone):
        pairs += [
            ("upper_inner", "upper_outer"),
            ("lower_outer", "upper_outer"),
            ("lower_inner", "spring_arm"),
            ("upper_outer", "contact"),
        ]
    else:
        pairs += [("lower_outer", "strut_lower"), ("strut_lower", "wheel_centre")]
    for a, b in pairs:
        np.testing.assert_allclose(dist(a, b, p), dist(a, b, d), atol=1e-10, err_msg=f"{a}-{b}")
    np.testing.assert_allclose(p["contact"][:, 1], float(g.contact_point[1]) + TRAVEL, atol=1e-9)
    if not isinstance(g, DoubleWishbone):
        # the strut axis (fixed in the upright through the lower seat) passes the top mount
        axis0 = g.strut_top - g.strut_lower
        c, s = np.cos(sweep.theta), np.sin(sweep.theta)
        axis = np.c_[c * axis0[0] - s * axis0[1], s * axis0[0] + c * axis0[1]]
        rel = g.strut_top - p["strut_lower"]
        np.testing.assert_allclose(
            (axis[:, 0] * rel[:, 1] - axis[:, 1] * rel[:, 0]) / np.linalg.norm(axis0), 0, atol=1e-10
        )


def test_batch_equals_one_by_one():
    names = ["double_wishbone", "double_wishbone_target", "parallel_equal_arms"]
    geoms = [load_geometry(n) for n in names]
    batch = stack_geometries(geoms)
    sb = sweep_outputs(batch, solve_sweep(batch, TRAVEL))
    for i, g in enumerate(geoms):
        si = sweep_outputs(g, solve_sweep(g, TRAVEL))
        np.testing.assert_allclose(sb.camber_deg[i], si.camber_deg, atol=1e-12)
        np.testing.assert_allclose(sb.half_track_mm[i], si.half_track_mm, atol=1e-9)


def test_lockup_is_reported_not_crashed():
    # the short upper arm cannot reach the upright 250 mm down in rebound: the two
    # circles of the loop closure stop meeting (checked by hand: fine at +-150 mm)
    g = load_geometry("double_wishbone")
    travel = np.linspace(-0.25, 0.25, 21)
    assert bool(solve_sweep(g, 0.6 * travel).ok)
    sweep = solve_sweep(g, travel)
    assert not bool(sweep.ok)
    assert sweep.messages[0].startswith("LockupError") and "-250.0" in sweep.messages[0]
    with pytest.raises(LockupError, match="cannot follow the travel"):
        solve_single(g, travel)
    # 400 mm parallel arms: the wheel cannot rise more than 400 mm; beyond, Newton would
    # find the other assembly branch, which the jump check must refuse
    par = load_geometry("parallel_equal_arms")
    assert bool(solve_sweep(par, np.linspace(-0.05, 0.39, 11)).ok)
    assert not bool(solve_sweep(par, np.linspace(-0.05, 0.45, 11)).ok)


# ------------------------------------------------------------- file format
def test_geometry_file_round_trip(tmp_path):
    import tomllib

    for name in ALL:
        g = load_geometry(name)
        path = tmp_path / f"{name}.toml"
        path.write_text(geometry_to_toml(g))
        back = load_geometry(path)
        assert back.points_mm() == g.points_mm()
        assert tomllib.loads(path.read_text())["kind"] == g.kind
        for f in ("tyre_radius", "static_camber", "spring_rate", "spring_preload"):
            assert float(getattr(back, f)) == pytest.approx(float(getattr(g, f)))


def test_geometry_name_with_quote_and_backslash_round_trips():
    import tomllib
    from dataclasses import replace

    g = replace(load_geometry("mcpherson"), name='front "A" \\ rig')
    back = geometry_from_dict(tomllib.loads(geometry_to_toml(g)))
    assert back.name == 'front "A" \\ rig'
    assert back.to_dict() == g.to_dict()


def test_bad_geometry_files_name_the_rule():
    with pytest.raises(ValidationError, match="`kind` must be one of"):
        geometry_from_dict({"kind": "trailing_arm"})
    with pytest.raises(ValidationError, match="missing=.*upper_inner"):
        geometry_from_dict({"kind": "double_wishbone", "points": {"lower_inner": [0, 0]}})
    d = load_geometry("mcpherson").to_dict()
    d["wheel"]["tyre_radius"] = -5
    with pytest.raises(ValidationError, match="tyre_radius > 0"):
        geometry_from_dict(d)
    with pytest.raises(ValidationError, match="neither a file nor a bundled example"):
        load_geometry("no_such_linkage")


# ------------------------------------------------- the two solvers agree
@pytest.mark.parametrize("name", ALL)
def test_analytic_and_pymunk_agree(name):
    g = load_geometry(name)
    a_sweep = solve_single(g, TRAVEL)
    p_sweep = simulate_sweep(g, TRAVEL)
    a, p = sweep_outputs(g, a_sweep), sweep_outputs(g, p_sweep)
    np.testing.assert_allclose(
        p_sweep.points["contact"][:, 1], a_sweep.points["contact"][:, 1], atol=1e-6
    )
    np.testing.assert_allclose(p.camber_deg, a.camber_deg, atol=1e-4)
    np.testing.assert_allclose(p.half_track_mm, a.half_track_mm, atol=1e-3)
    np.testing.assert_allclose(p.roll_centre_mm, a.roll_centre_mm, atol=0.3)
    np.testing.assert_allclose(p.motion_ratio, a.motion_ratio, atol=1e-3)
    np.testing.assert_allclose(p.wheel_load_N, a.wheel_load_N, atol=0.05)
    np.testing.assert_allclose(p.wheel_rate_N_per_mm, a.wheel_rate_N_per_mm, atol=0.1)


def test_pymunk_parallel_arms_matches_closed_form():
    # the same closed form as above, against the simulation directly
    g = load_geometry("parallel_equal_arms")
    L = float(np.linalg.norm(g.lower_outer - g.lower_inner))
    out = sweep_outputs(g, simulate_sweep(g, TRAVEL))
    psi = np.arcsin(TRAVEL / L)
    np.testing.assert_allclose(out.camber_deg, 0.0, atol=1e-4)
    np.testing.assert_allclose(out.half_track_mm, 1e3 * L * (np.cos(psi) - 1), atol=1e-3)


def test_pymunk_reports_the_same_lockup():
    # the linkage that cannot reach 250 mm of rebound analytically cannot follow the pad
    # there in the simulation either: a LockupError, not a hang or a wrong answer
    g = load_geometry("double_wishbone")
    travel = np.linspace(-0.25, 0.0, 6)
    assert not bool(solve_sweep(g, travel).ok)
    with pytest.raises(LockupError, match="cannot follow the pad"):
        simulate_sweep(g, travel)
