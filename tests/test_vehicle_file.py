"""Vehicle files: bounds in the file, physical validation, constants, bushing orientation,
assembly check and the exact round trip through dump_vehicle / load_vehicle."""

from __future__ import annotations

import dataclasses

import mcpherson_reference as reference
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from suspenv.core.errors import ValidationError
from suspenv.models.effects import make_effect
from suspenv.models.mcpherson import AxleConstants, AxleSolver, design_space
from suspenv.models.mcpherson.effects import axle_effect
from suspenv.models.mcpherson.params import (
    BUSHINGS,
    PARAMETER_NAMES,
    SIDE_SIGN,
    bushing_frames,
    default_bounds,
    euler_313,
)
from suspenv.models.mcpherson.solver import BUSH_ORDER
from suspenv.models.mcpherson.vehicle_checks import check_links
from suspenv.models.mcpherson.vehicle_file import (
    FAR_GEOMETRY_FILE,
    REFERENCE_FILE,
    VehicleFile,
    check_assembles,
    dump_vehicle,
    load_vehicle,
)
from suspenv.rigs.knc import run_tests

IDX = {n: i for i, n in enumerate(PARAMETER_NAMES)}


def write(tmp_path, text: str, name: str = "v.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------------------ bounds
def test_reference_file_space_is_the_paper_space():
    # reference: design_space(), the paper's (widened) bounds that KCIdentification uses
    space, paper = load_vehicle(REFERENCE_FILE).space(), design_space()
    assert space.names == paper.names
    assert np.array_equal(space.lower, paper.lower)
    assert np.array_equal(space.upper, paper.upper)
    assert np.array_equal(space.reference(), paper.reference())
    assert space.units == paper.units
    assert not any(p.log for p in space.parameters)


def test_default_bounds_follow_the_documented_rule():
    # reference: the rule of docs/knc.md "Vehicle files", written out by hand here
    v = load_vehicle(FAR_GEOMETRY_FILE)
    sp = v.space()
    lbj = sp.parameters[IDX["lower_ball_joint_y"]]
    assert (lbj.low, lbj.high, lbj.log) == pytest.approx((-950.57703, -930.57703, False))
    k = sp.parameters[IDX["top_mount_kx"]]
    assert (k.low, k.high, k.log) == (540.12, 54012.0, True)
    assert sp.to_unit(v.left)[0, IDX["top_mount_kx"]] == pytest.approx(0.5)  # log centre
    cam = sp.parameters[IDX["static_camber"]]
    assert (cam.low, cam.high) == pytest.approx((-2.9, -0.9))
    assert np.array_equal(sp.reference(), v.left)
    # an alignment near the physical limit keeps its bounds inside it
    assert default_bounds("static_toe", (9.5,)) == pytest.approx((8.5, 9.75, False))
    # both sides' nominal values lie inside the default bounds
    right = v.left.copy()
    right[IDX["strut_top_z"]] += 15.0
    w = dataclasses.replace(v, right=right)
    p = w.space().parameters[IDX["strut_top_z"]]
    assert (p.low, p.high) == (569.0, 604.0)


def test_explicit_bounds_with_log_scale_and_their_errors(tmp_path):
    ok = write(tmp_path, '[bounds]\nstrut_top_z = [550, 570]\ntop_mount_kx = [100, 9000, "log"]\n')
    sp = load_vehicle(ok).space()
    assert sp.parameters[IDX["strut_top_z"]].low == 550.0
    assert sp.parameters[IDX["top_mount_kx"]].log
    for text, expected in (
        ("[bounds]\nstrut_top_z = [570, 550]\n", r"`low < high` must hold, but got \[570, 550\]"),
        ("[bounds]\nstrut_top_z = [500, 550]\n", r"`low <= strut_top_z <= high`.*558.9"),
        ("[bounds]\ntop_mount_kx = [0, 9000]\n", r"top_mount_kx`: `low > 0` must hold"),
        ("[bounds]\nstatic_camber = [-12, 1]\n", r"static_camber`: `-10 < low`"),
        ("[bounds]\nstrut_top_z = [550]\n", r"strut_top_z must be \[low, high\]"),
        ("[bounds]\nstrut_top_z = [550, 600, 'cubic']\n", r"must be \[low, high\]"),
        ("[bounds]\nstrut_top_zz = [550, 600]\n", r"unknown parameter 'strut_top_zz'"),
        ("[bounds]\nstrut_top_z = [550, inf]\n", r"`strut_top_z high` must be a finite number"),
    ):
        with pytest.raises(ValidationError, match=expected):
            load_vehicle(write(tmp_path, text))


# ------------------------------------------------------------------- physics, not the box
def test_values_outside_the_paper_box_load_and_physics_is_refused(tmp_path):
    # the example: far hard points, camber -1.9 deg, a bushing above 50,000 N/mm
    far = write(
        tmp_path,
        "[design]\nlower_ball_joint_y = -900.0\nstrut_top_z = 850.0\n"
        "static_camber = -1.9\ntop_mount_kx = 2e5\n",
    )
    v = load_vehicle(far)
    assert v.left[IDX["lower_ball_joint_y"]] == -900.0
    assert design_space().outside_bounds(v.left)  # outside the paper's box, still fine
    for text, expected in (
        ("[design]\nlca_front_kx = 0.0\n", r"`lca_front_kx > 0` must hold .*lca_front_kx=0"),
        ("[design]\narb_torsion = -5.0\n", r"`arb_torsion > 0` must hold"),
        ("[design_right]\ntop_mount_rz = -1.0\n", r"\[design_right\]: `top_mount_rz > 0`"),
        ("[design]\nstatic_camber = 10.5\n", r"`\|static_camber\| < 10 deg` .*10.5"),
        ("[design]\nstatic_toe = -11\n", r"`\|static_toe\| < 10 deg`"),
        ("[design]\nstatic_toe = nan\n", r"\[design\]: `static_toe` must be a finite number"),
    ):
        with pytest.raises(ValidationError, match=expected):
            load_vehicle(write(tmp_path, text))


def test_vehicle_file_object_is_validated_on_construction():
    ref = load_vehicle(REFERENCE_FILE)
    bad = ref.left.copy()
    bad[IDX["top_mount_kz"]] = -1.0
    with pytest.raises(ValidationError, match=r"vehicle 'x' \[design\]: `top_mount_kz > 0`"):
        VehicleFile("x", bad, ref.left)
    with pytest.raises(ValidationError, match=r"orientation.*unknown bushing 'tie_rod'"):
        VehicleFile("x", ref.left, ref.left, orientation={"tie_rod": (0.0, 0.0, 0.0)})


# ------------------------------------------------------------------------------ constants
@pytest.mark.parametrize(
    ("field", "value", "rule"),
    [
        ("spring_rate", 0.0, "`spring_rate > 0`"),
        ("tyre_rate", -1.0, "`tyre_rate > 0`"),
        ("wheel_radius", 0.0, "`wheel_radius > 0`"),
        ("sprung_mass", -3.0, "`sprung_mass > 0`"),
        ("wheel_mass", 0.0, "`wheel_mass > 0`"),
        ("wheelbase", 0.0, "`wheelbase > 0`"),
        ("cg_height", -1.0, "`cg_height > 0`"),
        ("rack_travel_per_rev", 0.0, "`rack_travel_per_rev > 0`"),
        ("drop_link_d", 0.0, "`drop_link_d > 0`"),
        ("front_share", 1.0, "`0 < front_share < 1`"),
        ("front_brake_share", 1.5, "`0 <= front_brake_share <= 1`"),
        ("front_drive_share", -0.1, "`0 <= front_drive_share <= 1`"),
        ("spring_upper_seat_d", -5.0, "`0 <= spring_upper_seat_d < spring_lower_seat_d`"),
        ("spring_lower_seat_d", 30.0, "`0 <= spring_upper_seat_d < spring_lower_seat_d`"),
        ("wheel_centre", (0.0, float("nan"), 1.0), "`wheel_centre` must be a point"),
        ("drop_link_offset", (1.0, 2.0), "`drop_link_offset` must be a point"),
    ],
)
def test_every_constant_is_validated_with_rule_and_value(field, value, rule):
    with pytest.raises(ValidationError, match=f"AxleConstants: {rule}.*{field}="):
        AxleConstants(**{field: value})


def test_constant_errors_from_a_file_name_the_table(tmp_path):
    path = write(tmp_path, "[constants]\nfront_share = 0.0\n")
    with pytest.raises(ValidationError, match=r"v.toml \[constants\]: .*`0 < front_share < 1`"):
        load_vehicle(path)


# ----------------------------------------------------------------------------- assembly
def test_shipped_vehicles_assemble():
    for path in (REFERENCE_FILE, FAR_GEOMETRY_FILE):
        check_assembles(load_vehicle(path))


def test_check_assembles_refuses_with_the_reason(tmp_path):
    ref = load_vehicle(REFERENCE_FILE)
    x = ref.left.copy()
    for a in "xyz":  # strut top on the strut axis point: no strut line
        x[IDX[f"strut_top_{a}"]] = x[IDX[f"strut_axis_point_{a}"]]
    with pytest.raises(ValidationError, match=r"\|strut_top - strut_axis_point\| >= 1 mm"):
        check_assembles(VehicleFile("degenerate", x, x))
    x = ref.left.copy()
    f, r = (np.array([x[IDX[f"lca_{s}_bush_{a}"]] for a in "xyz"]) for s in ("front", "rear"))
    for a, v in zip("xyz", f + 2.0 * (r - f), strict=True):  # ball joint on the pivot axis
        x[IDX[f"lower_ball_joint_{a}"]] = v
    check_links(VehicleFile("on_axis", x, x).axle())  # the rule is check_assembles' own
    with pytest.raises(ValidationError, match="left lower ball joint must lie off"):
        check_assembles(VehicleFile("on_axis", x, x))
    # the right corner alone on its axis is refused by the same rule, naming its side
    with pytest.raises(ValidationError, match="right lower ball joint must lie off"):
        check_assembles(VehicleFile("on_axis_right", ref.left.copy(), x))
    # a top mount of 1e-3 N/mm cannot carry the spring preload: no static equilibrium
    x = ref.left.copy()
    for c in ("kx", "ky", "kz"):
        x[IDX[f"top_mount_{c}"]] = 1e-3
    path = write(tmp_path, dump_vehicle(VehicleFile("soft", x, x)))
    with pytest.raises(ValidationError, match=r"vehicle 'soft' does not assemble: \w+Error"):
        load_vehicle(path, assemble=True)
    load_vehicle(path)  # without the check the file itself is valid


# -------------------------------------------------------------------------- orientation
def test_euler_313_is_adams_body_fixed_zxz():
    # reference: scipy's intrinsic "ZXZ" Euler rotation (independent implementation)
    for angles in ((30.0, 0.0, 0.0), (0.0, 40.0, 0.0), (12.0, -70.0, 155.0)):
        expected = Rotation.from_euler("ZXZ", angles, degrees=True).as_matrix()
        assert np.allclose(euler_313(angles), expected, atol=1e-14)


def test_orientation_table_errors(tmp_path):
    for text, expected in (
        ("[orientation]\nlca_frnt = [0, 0, 0]\n", r"unknown bushing 'lca_frnt' \(did you mean"),
        ("[orientation]\nlca_front = [0, 0]\n", r"lca_front must be three Euler angles"),
        ("[orientation]\nlca_front = [0, nan, 0]\n", r"`lca_front` must be a finite number"),
    ):
        with pytest.raises(ValidationError, match=expected):
            load_vehicle(write(tmp_path, text))


def test_oriented_bushing_stiffness_is_r_k_rt_on_each_side():
    # reference: closed form K_vehicle = Q diag(k) Q^T with Q = M R M, R from scipy's
    # "ZXZ" Euler angles and M the side's ADAMS -> ISO point map; the solver's loads are
    # differentiated by central differences (they are linear in the deflection)
    angles = {"lca_front": (20.0, 35.0, -50.0), "top_mount": (-110.0, 15.0, 75.0)}
    ref = load_vehicle(REFERENCE_FILE)
    v = VehicleFile("rot", ref.left, ref.left, orientation=angles)
    solver = AxleSolver(v.axle())
    h = 1e-6
    J = np.zeros((2, 4, 6, 6))
    for j in range(6):
        dx = np.zeros((1, 2, 4, 6))
        dx[..., j] = h
        plus, minus = (reference.bushing_loads(solver, x, {}) for x in (dx, -dx))
        J[..., j] = (plus - minus)[0] / (2 * h)
    for s in (0, 1):
        M = np.diag([-1.0, -SIDE_SIGN[s], 1.0])
        for b, name in enumerate(BUSH_ORDER):
            R = Rotation.from_euler("ZXZ", angles.get(name, (0, 0, 0)), degrees=True).as_matrix()
            Q = M @ R @ M
            k = solver.K[name][0, s]
            for blk in (slice(0, 3), slice(3, 6)):
                expected = Q @ np.diag(k[blk]) @ Q.T
                got = J[s, b, blk, blk]
                assert np.allclose(got, expected, rtol=1e-7, atol=1e-9 * np.abs(k).max())
            assert np.abs(J[s, b, :3, 3:]).max() == 0 and np.abs(J[s, b, 3:, :3]).max() == 0


def _swapped(x: np.ndarray, bush: str, a: str, b: str) -> None:
    for kind in ("k", "r"):
        i, j = IDX.get(f"{bush}_{kind}{a}"), IDX.get(f"{bush}_{kind}{b}")
        if i is not None and j is not None:
            x[i], x[j] = x[j], x[i]


def test_rotated_bushing_with_swapped_stiffnesses_gives_the_same_axle():
    # reference: the unrotated axle. A top mount and an anti-roll-bar bush turned 90 deg
    # about z with kx<->ky and rx<->ry swapped, and a front lower-arm bush turned 90 deg
    # about x with ry<->rz swapped (its ky = kz), are the same stiffness in vehicle axes
    ref = load_vehicle(REFERENCE_FILE)
    x = ref.left.copy()
    _swapped(x, "top_mount", "x", "y")
    _swapped(x, "arb_bush", "x", "y")
    _swapped(x, "lca_front", "y", "z")
    turned = VehicleFile(
        "turned",
        x,
        x,
        orientation={
            "top_mount": (90.0, 0.0, 0.0),
            "arb_bush": (0.0, 0.0, 90.0),
            "lca_front": (0.0, 90.0, 0.0),
        },
    )
    tests = ("parallel", "opposite", "lateral")
    a = run_tests(ref.axle(), tests, steps=6)
    b = run_tests(turned.axle(), tests, steps=6)
    for t in tests:
        assert a[t].ok.all() and b[t].ok.all()
        for ch, tol in (("toe", 2e-6), ("camber", 2e-6), ("wheel_centre_y", 2e-6)):
            assert np.abs(a[t].channels[ch] - b[t].channels[ch]).max() < tol, (t, ch)
    # and the swap without the rotation is a different axle (the test can fail)
    plain = VehicleFile("swapped", x, x)
    c = run_tests(plain.axle(), ("lateral",), steps=6)["lateral"]
    assert np.abs(c.channels["toe"] - a["lateral"].channels["toe"]).max() > 1e-4


def test_identity_orientation_equals_no_orientation():
    ref = load_vehicle(REFERENCE_FILE)
    eye = VehicleFile("eye", ref.left, ref.left, orientation={b: (0.0, 0.0, 0.0) for b in BUSHINGS})
    assert AxleSolver(ref.axle())._Q is None  # the default path does not rotate at all
    a = run_tests(ref.axle(), ("lateral",), steps=4)["lateral"].channels["toe"]
    b = run_tests(eye.axle(), ("lateral",), steps=4)["lateral"].channels["toe"]
    assert np.abs(a - b).max() < 1e-12
    frames = bushing_frames({"lca_rear": (10.0, 20.0, 30.0)})["lca_rear"]
    assert np.allclose(np.linalg.det(frames), 1.0)  # a proper rotation on both sides


# ---------------------------------------------------------------------------- round trip
def test_dump_and_load_round_trip_exactly(tmp_path):
    far = load_vehicle(FAR_GEOMETRY_FILE)
    right = far.left.copy()
    right[IDX["tie_rod_outer_y"]] += 1.25
    right[IDX["top_mount_kz"]] *= 1.1
    v = VehicleFile(
        'asym "far" \u00e9\x7f\t',
        far.left,
        right,
        dataclasses.replace(far.constants, spring_rate=100.0 / 3.0),
        (
            axle_effect("dahl_hysteresis", "lower_arm", f_c=80.0),
            axle_effect("coulomb_friction", "strut", f_c=20.0),
        ),
        'a description with "quotes" and a back\\slash',
        {"strut_top_z": (570.0, 590.0, False), "lca_rear_kx": (100.0, 1e5, True)},
        dict(far.orientation),
    )
    back = load_vehicle(write(tmp_path, dump_vehicle(v)))
    assert back.name == v.name and back.description == v.description
    assert np.array_equal(back.left, v.left) and np.array_equal(back.right, v.right)
    assert back.constants == v.constants
    assert back.orientation == v.orientation
    sv, sb = v.space(), back.space()
    assert np.array_equal(sv.lower, sb.lower) and np.array_equal(sv.upper, sb.upper)
    assert [p.log for p in sv.parameters] == [p.log for p in sb.parameters]
    assert [(e.kind, e.location, e.name, e.params) for e in back.effects] == [
        (e.kind, e.location, e.name, e.params) for e in v.effects
    ]
    # a batch-valued effect parameter cannot be written as one vehicle: refused by name
    batch = dataclasses.replace(v, effects=(make_effect("coulomb_friction", f_c=np.ones(2)),))
    with pytest.raises(ValidationError, match="must be a scalar"):
        dump_vehicle(batch)


def test_with_design_keeps_the_identification_space(tmp_path):
    # an identified vehicle keeps the bounds it was identified in (the far car has
    # default bounds, which would otherwise move with the new nominal values)
    far = load_vehicle(FAR_GEOMETRY_FILE)
    x = far.left.copy()
    x[IDX["strut_top_z"]] += 8.0
    x[IDX["top_mount_kx"]] *= 3.0
    ident = far.with_design(x, name="identified")
    assert np.array_equal(ident.space().lower, far.space().lower)
    assert np.array_equal(ident.space().upper, far.space().upper)
    assert np.array_equal(ident.right, x) and ident.name == "identified"
    back = load_vehicle(write(tmp_path, dump_vehicle(ident)))
    assert np.array_equal(back.space().upper, far.space().upper)
    assert back.orientation == far.orientation
    x[IDX["strut_top_z"]] += 5.0  # now outside the kept bounds: refused by name
    with pytest.raises(ValidationError, match=r"`low <= strut_top_z <= high`"):
        far.with_design(x)
