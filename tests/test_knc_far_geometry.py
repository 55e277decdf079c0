"""A McPherson axle far from the paper's geometry (the shipped file built from Project
Chrono's generic MacPherson strut): it loads, assembles, runs every rig test, matches an
independent ideal-joint solver in the rigid limit and is mirror-symmetric.

The rigid-limit reference is :class:`mcpherson_kinematics.CornerKinematics`:
six closure equations in the knuckle pose alone (lower-arm radius to both bushes, tie-rod
length, strut top on the strut line, wheel-centre height), solved by Newton's method with
scipy's rotations. It shares no code with the compliant solver (``solver.py``, 4 bodies x
6 coordinates, bushings as springs, Lagrange multipliers, ``rotation.py``) except the
input geometry (``build_axle``); the alignment angles below are computed here from their
definitions, not by the solver's ``outputs``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from knc_checks import XTOL, channel_tolerance
from mcpherson_kinematics import CornerKinematics
from scipy.spatial.transform import Rotation

from suspenv.models.mcpherson import design_space
from suspenv.models.mcpherson.params import BUSHINGS, PARAMETER_NAMES
from suspenv.models.mcpherson.vehicle_file import FAR_GEOMETRY_FILE, check_assembles, load_vehicle
from suspenv.rigs.knc import ALL_TESTS, run_tests

IDX = {n: i for i, n in enumerate(PARAMETER_NAMES)}


@pytest.fixture(scope="module")
def far():
    return load_vehicle(FAR_GEOMETRY_FILE)


def test_far_vehicle_lies_outside_the_paper_box_and_assembles(far):
    out = design_space().outside_bounds(far.left)
    assert len(out) >= 20, out  # nearly every hard point and the camber
    check_assembles(far)
    res = run_tests(far.axle(), ALL_TESTS, steps=4, effects=far.effects)
    failed = {t: r.messages for t, r in res.items() if not r.ok.all()}
    assert not failed


def rigid(x: np.ndarray) -> np.ndarray:
    """Bushings stiff in translation (1e8 N/mm) and nearly free in rotation (1e-2 N*mm/deg):
    the compliant model's limit is the ideal-joint linkage (revolute lower arm about the
    bushes' line, spherical top mount)."""
    x = x.copy()
    for b, comps in BUSHINGS.items():
        for c in comps:
            x[IDX[f"{b}_{c}"]] = 1e8 if c.startswith("k") else 1e-2
    return x


def _alignment(R: np.ndarray, camber0: float, toe0: float, lbj: np.ndarray, top: np.ndarray):
    """Toe, camber, caster [rad] of the LEFT wheel (y > 0 outboard) from the knuckle
    rotation R (..., 3, 3), by their definitions (docs/knc.md): spin axis s (outboard)
    at design from static camber c and toe t: s = (sin t cos c, cos t cos c, -sin c)
    (toe-in turns the wheel's front inboard, -y; negative camber tilts s up);
    camber = -asin(s_z); heading h = s x z (forward), toe = -atan2(h_y, h_x);
    caster = atan2(-k_x, k_z), k from the lower ball joint to the strut top."""
    s0 = np.array(
        [np.sin(toe0) * np.cos(camber0), np.cos(toe0) * np.cos(camber0), -np.sin(camber0)]
    )
    s = R @ s0
    h = np.cross(s, [0.0, 0.0, 1.0])
    k = top - lbj
    return (
        -np.arctan2(h[..., 1], h[..., 0]),
        -np.arcsin(s[..., 2]),
        np.arctan2(-k[..., 0], k[..., 2]),
    )


def test_rigid_limit_matches_the_ideal_joint_solver_to_4_significant_figures(far):
    # reference: CornerKinematics (module docstring), at the wheel-centre heights the
    # compliant rig reached along its parallel-travel loop (pads +-80 mm: about +-40 mm
    # at the wheel centre, the spring and the tyre share the stroke)
    v = dataclasses.replace(far, left=rigid(far.left), right=rigid(far.right))
    axle = v.axle()
    res = run_tests(axle, ("parallel",), amplitude=0.080, steps=8)["parallel"]
    assert res.ok.all(), res.messages
    ch = res.channels
    kin = CornerKinematics(axle)
    q = None
    got = {k: [] for k in ("toe", "camber", "caster", "wheel_centre_x", "wheel_centre_y")}
    for i in range(ch["wheel_centre_z"].shape[1]):
        z = ch["wheel_centre_z"][:, i, :]
        q = kin.solve(z, q)
        R = Rotation.from_rotvec(q[0, 0, 3:]).as_matrix()
        wc = kin.wc0[0, 0] + q[0, 0, :3]
        lbj = wc + R @ (kin.B[0, 0] - kin.wc0[0, 0])
        toe, camber, caster = _alignment(R, axle.camber0[0, 0], axle.toe0[0, 0], lbj, kin.ST[0, 0])
        for k, val in zip(got, (toe, camber, caster, wc[0], wc[1]), strict=True):
            got[k].append(val)
    travel = ch["wheel_centre_z"][0, :, 0] - kin.wc0[0, 0, 2]
    assert np.ptp(travel) > 0.07  # the loop covers about +-40 mm of wheel travel
    for k, ref in got.items():
        ref = np.array(ref)
        sim = ch[k][0, :, 0]
        # 4 significant figures of each curve: error below 0.5e-4 of its largest value,
        # and of its change over the travel (the part the geometry decides)
        scale = min(np.abs(ref).max(), np.ptp(ref))
        err = np.abs(sim - ref).max()
        assert err < 0.5e-4 * scale, (k, err, scale)
    # the far geometry is really different: caster of the Chrono strut, not the paper's
    assert np.degrees(got["caster"][0]) == pytest.approx(7.07, abs=0.05)


def test_far_axle_is_mirror_symmetric(far):
    # reference: mirror symmetry about the x-z plane (the right side is the mirror of
    # the left, including the oriented lower-arm bushes): parallel travel gives equal
    # left and right alignment and mirrored wheel centres; opposite travel's left wheel
    # at +s is the right wheel at -s
    res = run_tests(far.axle(), ("parallel", "opposite"), steps=6)
    par, opp = res["parallel"], res["opposite"]
    assert par.ok.all() and opp.ok.all()
    # tolerances: each side is converged to the solver's tolerances (steps below 1e-6 m,
    # 1e-5 rad) on its own round-off, so the two sides may differ by twice those; the
    # tyre force by twice the tyre rate times 1e-6 m. A mirror error is millimetres.
    kt = far.constants.tyre_rate * 1e3  # N/m
    for name in ("toe", "camber", "caster", "kpi", "wheel_centre_x", "wheel_centre_z", "tyre_fz"):
        tol = 2 * (kt * XTOL if name == "tyre_fz" else channel_tolerance(name))
        c = par.channels[name]
        assert np.allclose(c[..., 0], c[..., 1], rtol=0, atol=tol), name
        for br in ("down", "up"):
            b = opp.branch(name, br)
            assert np.allclose(b[:, :, 0], b[:, ::-1, 1], rtol=0, atol=tol), name
    y = par.channels["wheel_centre_y"]
    assert np.allclose(y[..., 0], -y[..., 1], rtol=0, atol=2 * XTOL)
    assert np.abs(par.channels["toe"]).max() > 1e-3  # toe moves (the check can fail)
