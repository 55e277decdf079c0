"""Definitions of the 40 K&C objectives of the McPherson front axle (Tey et al. 2014).

Four kinds of test, each saying where its reference comes from:

* golden (snapshot): every objective and a few main channels against
  ``tests/golden/knc_reference.json`` (written by ``tools/make_golden_knc.py``). It only
  guards against regressions; it does not show that the numbers are right;
* definitions recomputed a second way from the raw rig channels, following the table
  "The 40 objectives" of ``docs/knc.md`` (independent least squares with
  ``np.polyfit``, central finite differences, chain-rule and series-spring hand
  calculations), and sign conventions checked against geometry (ISO 8855: x forward,
  y left, z up; outboard = +y on the left wheel, -y on the right);
* left/right: on a car with left/right manufacturing tolerances the parallel and
  opposite objectives are the mean of the two wheels, the single-wheel ones the
  moving (left) wheel's;
* variation: every objective changes over a small design of experiments.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import qmc

from suspenv.metrics.knc import OBJECTIVE_NAMES, OBJECTIVE_UNITS, objectives
from suspenv.models.mcpherson import AxleConstants, build_axle, design_space, reference_design
from suspenv.models.mcpherson.params import HARD_POINTS, PARAMETER_NAMES
from suspenv.models.mcpherson.truth import truth_vehicle
from suspenv.rigs.knc import ALL_TESTS, FORCE_AMPLITUDE, TESTS, run_tests

GOLDEN = Path(__file__).resolve().parent / "golden" / "knc_reference.json"
AMPLITUDE = 0.040  # m; the identification problem's rig (paper: +-40 mm, 30 intervals)
STEPS = 30
HALF = 3  # fit window: 7 grid points centred on the static position (docs/knc.md)
#: ISO 8855 y is to the left: outboard is +y on the left wheel (0), -y on the right (1)
OUTBOARD = np.array([1.0, -1.0])
BRANCHES = ("down", "up")

# ------------------------------------------------------------------ fixtures


def _run(axle, tests=TESTS, effects=(), keep_states=False):
    res = run_tests(
        axle,
        tests,
        amplitude=AMPLITUDE,
        steps=STEPS,
        effects=effects,
        keep_states=keep_states,
        force_amplitude=FORCE_AMPLITUDE,
    )
    for name, r in res.items():
        assert r.ok.all(), (name, r.messages)
    return res


@pytest.fixture(scope="module")
def ref():
    """The reference vehicle (mirrored axle), all five rig tests, states kept."""
    return _run(build_axle(reference_design()[None, :]), ALL_TESTS, keep_states=True)


@pytest.fixture(scope="module")
def ref_obj(ref):
    return dict(zip(OBJECTIVE_NAMES, objectives(ref)[0], strict=True))


@pytest.fixture(scope="module")
def car():
    """The identification problem's test car without sensor noise: left/right
    manufacturing tolerances (1 mm, 10 %, 0.05 deg) and rubber hysteresis."""
    tv = truth_vehicle(seed=0, noise=False)
    assert not np.allclose(tv.left, tv.right)
    return _run(tv.axle(), effects=tv.effects)


@pytest.fixture(scope="module")
def car_obj(car):
    return dict(zip(OBJECTIVE_NAMES, objectives(car)[0], strict=True))


def _doe_box(u: np.ndarray) -> np.ndarray:
    """Unit-cube samples -> designs: reference +-5 mm (hard points), +-20 % (bushings,
    anti-roll bar), +-0.2 deg (static alignment), clipped to the identification bounds."""
    x0 = reference_design()
    hp = np.array([n.rsplit("_", 1)[0] in HARD_POINTS for n in PARAMETER_NAMES])
    align = np.array([n.startswith("static_") for n in PARAMETER_NAMES])
    half = np.where(hp, 5.0, np.where(align, 0.2, 0.2 * np.abs(x0)))
    sp = design_space()
    return np.clip(x0 - half + 2.0 * half * u, sp.lower, sp.upper)


@pytest.fixture(scope="module")
def doe():
    """10 axles, Latin hypercube: (asymmetric, symmetric) results. Asymmetric: left and
    right sides drawn independently (the measured car); symmetric: the left sides
    mirrored (the identification model)."""
    u = qmc.LatinHypercube(d=2 * len(PARAMETER_NAMES), seed=7).random(10)
    left, right = _doe_box(u[:, : len(PARAMETER_NAMES)]), _doe_box(u[:, len(PARAMETER_NAMES) :])
    return _run(build_axle(left, right)), _run(build_axle(left))


# ------------------------------------------- independent definitions (docs/knc.md)


def fit(x: np.ndarray, y: np.ndarray, c: int) -> tuple[float, float, float]:
    """(value, slope, curvature 2c) at ``x[c]`` of a least-squares quadratic through the
    7 points ``c +- 3`` (np.polyfit; the product code has its own normal equations)."""
    sl = slice(c - HALF, c + HALF + 1)
    a2, a1, a0 = np.polyfit(x[sl] - x[c], y[sl], 2)
    return a0, a1, 2.0 * a2


def curves(res, branch: str, row: int = 0) -> dict[str, np.ndarray]:
    """The curves of docs/knc.md in edge units (mm, deg, N, N*m) from the raw SI
    channels of one design: per wheel (G, 2), axle curves (G,)."""

    def ch(name):
        return res.branch(name, branch)[row]

    c = res.static_index
    zw, zp = ch("wheel_centre_z") * 1e3, ch("pad_z") * 1e3
    out = {
        "toe": np.degrees(ch("toe")),
        "camber": np.degrees(ch("camber")),
        "caster": np.degrees(ch("caster")),
        "hub_lateral": ch("wheel_centre_y") * 1e3 * OUTBOARD,
        "contact_lateral": ch("contact_y") * 1e3 * OUTBOARD,
        "hub_fore_aft": ch("wheel_centre_x") * 1e3,
        "contact_fore_aft": ch("contact_x") * 1e3,
        "fz": ch("tyre_fz"),
        "wheel": zw - zw[c],
        "pad": zp - zp[c],
    }
    track = ch("wheel_centre_y")[c, 0] - ch("wheel_centre_y")[c, 1]  # m, wheel centres
    phi = np.degrees(np.arctan((zw[:, 0] - zw[:, 1]) / 1e3 / track))
    phi = phi - phi[c]  # roll, positive when the left wheel rises relative to the body
    out["roll_own"] = np.stack([phi, -phi], axis=1)  # each wheel's own sense
    out["roll"] = phi
    out["half_dfz"] = 0.5 * (out["fz"][:, 0] - out["fz"][:, 1])
    out["half_dzw"] = 0.5 * (out["wheel"][:, 0] - out["wheel"][:, 1])
    t_cp = ch("contact_y")[c, 0] - ch("contact_y")[c, 1]  # m, contact-point track
    out["roll_moment"] = out["half_dfz"] * t_cp
    return out


#: rows 1-13 of docs/knc.md (parallel) and 27-39 (single): suffix -> (curve, against, number)
TRAVEL = {
    "susp_ride_rate": ("fz", "wheel", "curvature"),
    "susp_ride_rate_pos": ("fz", "wheel", "slope"),
    "toe": ("toe", "wheel", "slope"),
    "toe_pos": ("toe", "wheel", "value"),
    "camber": ("camber", "wheel", "slope"),
    "camber_pos": ("camber", "wheel", "value"),
    "hub_lateral": ("hub_lateral", "wheel", "slope"),
    "susp_contact_lateral": ("contact_lateral", "wheel", "slope"),
    "hub_fore_aft": ("hub_fore_aft", "wheel", "slope"),
    "caster": ("caster", "wheel", "slope"),
    "ride_rate": ("fz", "pad", "curvature"),
    "contact_lateral": ("contact_lateral", "pad", "slope"),
    "contact_fore_aft": ("contact_fore_aft", "pad", "slope"),
}
#: rows 14-26 of docs/knc.md (opposite travel)
OPPOSITE = {
    "opp_toe": ("toe", "wheel", "slope"),
    "opp_toe_pos": ("toe", "wheel", "value"),
    "opp_camber": ("camber", "wheel", "slope"),
    "opp_camber_pos": ("camber", "wheel", "value"),
    "opp_roll_caster": ("caster", "roll_own", "slope"),
    "opp_roll_toe": ("toe", "roll_own", "slope"),
    "opp_roll_toe_pos": ("toe", "roll_own", "value"),
    "opp_roll_camber": ("camber", "roll_own", "slope"),
    "opp_roll_camber_pos": ("camber", "roll_own", "value"),
    "opp_roll_force": ("half_dfz", "half_dzw", "curvature"),
    "opp_roll_force_pos": ("half_dfz", "half_dzw", "slope"),
    "opp_roll_rate": ("roll_moment", "roll", "curvature"),
    "opp_roll_rate_pos": ("roll_moment", "roll", "slope"),
}
#: name -> (test, curve, against, number)
DEFINITIONS = (
    {f"par_{k}": ("parallel", *v) for k, v in TRAVEL.items()}
    | {k: ("opposite", *v) for k, v in OPPOSITE.items()}
    | {f"sgl_{k}": ("single", *v) for k, v in TRAVEL.items()}
    | {"sgl_ride_rate_pos": ("single", "fz", "pad", "slope")}  # row 40
)
AXLE_CURVES = {"half_dfz", "roll_moment"}
NUMBER = {"value": 0, "slope": 1, "curvature": 2}


def per_wheel(results, name: str, row: int = 0, wheels: tuple[int, ...] | None = None):
    """Objective ``name`` of each wheel (2,), mean of the two branches (docs/knc.md:
    Tey et al. used the average of the loop at the static position). An axle curve
    gives the same number on both wheels. Single wheel travel: the left wheel only (the
    right wheel's pad does not move, so its pad-travel curves have no abscissa); the
    right entry is NaN unless ``wheels`` asks for it."""
    test, curve, against, number = DEFINITIONS[name]
    if wheels is None:
        wheels = (0,) if test == "single" else (0, 1)
    res = results[test]
    c = res.static_index
    vals = np.full((len(BRANCHES), 2), np.nan)
    for b, br in enumerate(BRANCHES):
        cv = curves(res, br, row)
        if curve in AXLE_CURVES:
            vals[b, :] = fit(cv[against], cv[curve], c)[NUMBER[number]]
        else:
            for w in wheels:
                vals[b, w] = fit(cv[against][:, w], cv[curve][:, w], c)[NUMBER[number]]
    return vals.mean(axis=0)


def documented(results, name: str, row: int = 0) -> float:
    """The objective as docs/knc.md defines it: parallel and opposite travel average the
    left and right wheels, single travel takes the moving (left) wheel."""
    w = per_wheel(results, name, row)
    return float(w[0] if DEFINITIONS[name][0] == "single" else w.mean())


def central_difference(res, yname, xname, wheel, ys=1.0, xs=1.0) -> float:
    """dy/dx at static from the grid points either side, mean of the branches (raw SI
    channels scaled by ``ys``, ``xs``)."""
    c = res.static_index
    d = []
    for br in BRANCHES:
        y = res.branch(yname, br)[0, :, wheel] * ys
        x = res.branch(xname, br)[0, :, wheel] * xs
        d.append((y[c + 1] - y[c - 1]) / (x[c + 1] - x[c - 1]))
    return float(np.mean(d))


# ------------------------------------------------------------------ golden


@pytest.fixture(scope="module")
def golden():
    return json.loads(GOLDEN.read_text())


def _close(a: float, b: float, rtol: float = 1e-6, atol: float = 0.0) -> bool:
    return bool(np.isfinite(a) and abs(a - b) <= rtol * abs(b) + atol)


def test_golden_has_the_same_forty_objective_names(golden):
    # reference: the snapshot; a renamed, added or removed objective fails here
    for key, veh in golden["vehicles"].items():
        assert len(veh["objectives"]) == 40, key
        assert set(veh["objectives"]) == set(OBJECTIVE_NAMES), (
            key,
            sorted(set(veh["objectives"]) ^ set(OBJECTIVE_NAMES)),
        )
    assert len(OBJECTIVE_NAMES) == 40 == len(set(OBJECTIVE_NAMES))


def test_golden_rig_settings_match_this_file(golden):
    # reference: the snapshot's header; the fixtures must run the same rig
    rig = golden["header"]["rig"]
    assert rig["amplitude_mm"] == AMPLITUDE * 1e3 and rig["steps"] == STEPS
    assert rig["force_amplitude_N"] == FORCE_AMPLITUDE


#: the solver's stopping rule on a multiplier (a pad load): its last Newton correction
#: is below this (KinematicSolver's ltol, N; see models/mcpherson/solver.py)
LTOL_N = 0.1
#: an upper bound on a car's track at the contact patches [m]
TRACK_BOUND_M = 2.0
#: objectives zero by symmetry on the mirrored reference axle, and the bound on their
#: channel's error [channel unit]: in the opposite-travel test the mirror maps roll
#: phi -> -phi and the load difference (and roll moment) to minus itself, so both
#: curves are odd and their curvature vanishes. What is left is the solver's stopping
#: error: each pad load within LTOL_N, so the half load difference within LTOL_N [N]
#: and the roll moment 0.5 (Fz_L - Fz_R) t within LTOL_N * TRACK_BOUND_M [N*m].
SYMMETRY_ZEROS = {
    "opp_roll_force": ("half_dfz", "half_dzw", LTOL_N),
    "opp_roll_rate": ("roll_moment", "roll", LTOL_N * TRACK_BOUND_M),
}


def curvature_bound(x: np.ndarray, c: int, channel_error: float) -> float:
    """The largest curvature (2 a2) the 7-point quadratic fit can make of a channel whose
    points are each off by at most ``channel_error``: that error times the L1 norm of
    the fit's curvature weights (the fit is linear in y; weights from np.polyfit on the
    unit vectors)."""
    sl = slice(c - HALF, c + HALF + 1)
    weights = 2.0 * np.polyfit(x[sl] - x[c], np.eye(2 * HALF + 1), 2)[0]
    return channel_error * float(np.abs(weights).sum())


def test_golden_objectives(golden, ref_obj, car_obj):
    # reference: snapshot (tools/make_golden_knc.py), regressions only; rtol 1e-6
    # against values rounded to 7 significant figures. The reference's two quantities
    # zero by symmetry are round-off of the solver's stopping point (they differ
    # between BLAS kernels), so they are checked against the bound of test_symmetry_zeros
    # instead of the snapshot
    computed = {"reference": ref_obj, "truth_vehicle_seed0_no_noise": car_obj}
    bad = []
    for key, veh in golden["vehicles"].items():
        got = computed[veh["recipe"]]
        for name, want in veh["objectives"].items():
            if key == "reference" and name in SYMMETRY_ZEROS:
                continue
            if name in got and not _close(got[name], want):
                bad.append(f"{key}.{name}: {got[name]:.9g} != golden {want:.9g}")
    assert not bad, "objectives differ from the snapshot:\n" + "\n".join(bad)


def test_symmetry_zeros(ref, ref_obj, car_obj):
    # reference: mirror symmetry of the reference axle (see SYMMETRY_ZEROS) and the
    # solver's stopping tolerance; the test car (left/right tolerances) must exceed the
    # bound, or the check could not tell a broken symmetry from round-off
    res = ref["opposite"]
    for name, (_curve, against, error) in SYMMETRY_ZEROS.items():
        bounds = [
            curvature_bound(curves(res, br)[against], res.static_index, error) for br in BRANCHES
        ]
        bound = max(bounds)
        assert abs(ref_obj[name]) <= bound, (name, ref_obj[name], bound)
        assert abs(car_obj[name]) > bound, (name, car_obj[name], bound)


def test_golden_channels(golden, ref):
    # reference: snapshot (tools/make_golden_knc.py), regressions only; raw channels of
    # all five rig tests at 5 grid points, both branches and wheels
    head = golden["header"]
    idx = head["rig"]["channels_at_grid_index"]
    scale = {"deg": 180.0 / np.pi, "mm": 1e3, "N": 1.0}
    bad = []
    snap = golden["vehicles"]["reference"]["channels"]
    # the snapshot holds the three travel tests and the lateral and longitudinal ones
    assert set(TESTS) | {"lateral", "longitudinal"} <= set(snap) <= set(ALL_TESTS)
    for test, entry in snap.items():
        res = ref[test]
        grid = res.grid[idx] * (1e3 if entry["grid_unit"] == "mm" else 1.0)
        assert np.allclose(grid, entry["grid"], rtol=1e-6), test
        for br in BRANCHES:
            for name, want in entry[br].items():
                got = res.branch(name, br)[0][idx] * scale[head["channel_units"][name]]
                want = np.asarray(want)
                # atol: 1e-7 of the channel's range, for points where it crosses zero
                atol = 1e-7 * np.abs(want).max()
                ok = np.abs(got - want) <= 1e-6 * np.abs(want) + atol
                if not ok.all():
                    bad.append(f"{test}.{br}.{name}: {got[~ok]} != golden {want[~ok]}")
    assert not bad, "channels differ from the snapshot:\n" + "\n".join(bad)


# ------------------------------------------------------- definitions, second way


@pytest.mark.parametrize("vehicle", ["reference", "test_car"])
def test_every_objective_equals_its_documented_definition(vehicle, ref, car):
    # reference: docs/knc.md table "The 40 objectives" re-implemented above from the raw
    # channels (np.polyfit over the 7 points around static, mean of the two branches,
    # L/R mean or moving wheel). The test car adds asymmetry and hysteresis.
    results = ref if vehicle == "reference" else car
    F = dict(zip(OBJECTIVE_NAMES, objectives(results)[0], strict=True))
    assert set(DEFINITIONS) == set(OBJECTIVE_NAMES)
    bad = []
    for name in OBJECTIVE_NAMES:
        want = documented(results, name)
        # atol: polyfit and the normal equations differ by rounding (1e-9 of the data)
        if not _close(F[name], want, rtol=1e-7, atol=1e-9):
            bad.append(f"{name}: {F[name]:.9g}, documented definition gives {want:.9g}")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize(
    ("name", "test", "yname", "xname", "ys", "xs"),
    [
        # gradient [edge unit per mm of wheel or pad travel]; rad -> deg, m -> mm here
        ("par_toe", "parallel", "toe", "wheel_centre_z", 180 / np.pi, 1e3),
        ("par_camber", "parallel", "camber", "wheel_centre_z", 180 / np.pi, 1e3),
        ("par_caster", "parallel", "caster", "wheel_centre_z", 180 / np.pi, 1e3),
        ("par_hub_fore_aft", "parallel", "wheel_centre_x", "wheel_centre_z", 1e3, 1e3),
        ("par_susp_ride_rate_pos", "parallel", "tyre_fz", "wheel_centre_z", 1.0, 1e3),
        ("par_contact_fore_aft", "parallel", "contact_x", "pad_z", 1e3, 1e3),
        ("opp_toe", "opposite", "toe", "wheel_centre_z", 180 / np.pi, 1e3),
        ("opp_camber", "opposite", "camber", "wheel_centre_z", 180 / np.pi, 1e3),
        ("sgl_toe", "single", "toe", "wheel_centre_z", 180 / np.pi, 1e3),
        ("sgl_camber", "single", "camber", "wheel_centre_z", 180 / np.pi, 1e3),
        ("sgl_susp_ride_rate_pos", "single", "tyre_fz", "wheel_centre_z", 1.0, 1e3),
        ("sgl_ride_rate_pos", "single", "tyre_fz", "pad_z", 1.0, 1e3),
    ],
)
def test_gradients_agree_with_a_central_finite_difference(
    ref, ref_obj, name, test, yname, xname, ys, xs
):
    # reference: central difference over +-1 grid step (2.7 mm) of the raw channel at
    # the static position, a different estimator than the 7-point quadratic; they agree
    # to O(h^2), 0.2 % at most on the reference, checked to 1 %. The left wheel suffices:
    # the reference axle is mirrored.
    fd = central_difference(ref[test], yname, xname, 0, ys, xs)
    assert abs(fd) > 0
    assert ref_obj[name] == pytest.approx(fd, rel=0.01)


@pytest.mark.parametrize(
    ("name", "test", "xname"),
    [
        ("par_susp_ride_rate", "parallel", "wheel_centre_z"),
        ("par_ride_rate", "parallel", "pad_z"),
        ("sgl_susp_ride_rate", "single", "wheel_centre_z"),
        ("sgl_ride_rate", "single", "pad_z"),
    ],
)
def test_rate_gradients_are_the_second_derivative_of_the_wheel_load(
    ref, ref_obj, name, test, xname
):
    # reference: docs/knc.md, "rate gradient = curvature 2c" = d2F/dx2 of the tyre load;
    # here the three-point second difference over +-1 grid step (uneven spacing) of the
    # raw channel, mean of the branches, left wheel; agrees to 0.5 % on the reference
    res = ref[test]
    c = res.static_index
    d2 = []
    for br in BRANCHES:
        y = res.branch("tyre_fz", br)[0, c - 1 : c + 2, 0]
        x = res.branch(xname, br)[0, c - 1 : c + 2, 0] * 1e3  # mm
        d2.append(
            2 * ((y[2] - y[1]) / (x[2] - x[1]) - (y[1] - y[0]) / (x[1] - x[0])) / (x[2] - x[0])
        )
    assert ref_obj[name] == pytest.approx(np.mean(d2), rel=0.01)


def test_value_objectives_are_the_channels_at_the_static_position(ref, ref_obj):
    # reference: docs/knc.md, "value" = fit at the static abscissa; on a smooth curve it
    # is the channel at the static grid point (the quadratic's residual there is tiny)
    for prefix, test in (("par", "parallel"), ("opp", "opposite"), ("sgl", "single")):
        res = ref[test]
        c = res.static_index
        toe = np.degrees(res.mean_branch("toe")[0, c, 0])
        camber = np.degrees(res.mean_branch("camber")[0, c, 0])
        assert ref_obj[f"{prefix}_toe_pos"] == pytest.approx(toe, abs=1e-5)  # deg
        assert ref_obj[f"{prefix}_camber_pos"] == pytest.approx(camber, abs=1e-5)
    # the reference's static camber is negative (parameter -0.52 deg, top inboard)
    assert ref_obj["par_camber_pos"] < -0.3


def test_roll_objectives_follow_from_the_wheel_travel_ones_by_the_chain_rule(ref, ref_obj):
    # reference: hand calculation. Opposite travel of a mirrored axle moves the wheel
    # centres by +z and -z, so phi = atan(2 z / t) and dz/dphi = t/2 [mm/rad], t the
    # wheel-centre track; roll rate dM/dphi with M = (F_L - F_R)/2 * t_cp is then the
    # roll force rate times t_cp * t/2 (per degree: times pi/180)
    opp = ref["opposite"]
    c = opp.static_index
    y = opp.mean_branch("wheel_centre_y")[0, c]
    t_mm = (y[0] - y[1]) * 1e3
    cy = opp.mean_branch("contact_y")[0, c]
    t_cp = cy[0] - cy[1]  # m
    mm_per_deg = 0.5 * t_mm * np.pi / 180.0
    for q in ("toe", "camber"):
        assert ref_obj[f"opp_roll_{q}"] == pytest.approx(ref_obj[f"opp_{q}"] * mm_per_deg, rel=2e-3)
    assert ref_obj["opp_roll_rate_pos"] == pytest.approx(
        ref_obj["opp_roll_force_pos"] * t_cp * mm_per_deg, rel=2e-3
    )
    # docs/knc.md quotes the reference's roll rate: 2164 N*m/deg
    assert ref_obj["opp_roll_rate_pos"] == pytest.approx(2164, abs=1)


def test_ride_rate_is_the_suspension_rate_in_series_with_the_tyre(ref_obj):
    # reference: hand calculation, springs in series: the pad moves by the wheel travel
    # plus the tyre deflection, 1/k_ride = 1/k_wheel + 1/k_tyre (tyre rate from
    # AxleConstants; the small difference is the contact point's own height change)
    kt = AxleConstants().tyre_rate
    series = 1.0 / (1.0 / ref_obj["sgl_susp_ride_rate_pos"] + 1.0 / kt)
    assert ref_obj["sgl_ride_rate_pos"] == pytest.approx(series, rel=2e-3)
    # single wheel: the anti-roll bar adds to the wheel rate, so it exceeds the parallel one
    assert ref_obj["sgl_susp_ride_rate_pos"] > ref_obj["par_susp_ride_rate_pos"] + 5


# ------------------------------------------------------------------ signs


@pytest.mark.parametrize(
    ("names", "yname", "xname"),
    [
        (("par_hub_lateral", "sgl_hub_lateral"), "wheel_centre_y", "wheel_centre_z"),
        (("par_susp_contact_lateral", "sgl_susp_contact_lateral"), "contact_y", "wheel_centre_z"),
        (("par_contact_lateral", "sgl_contact_lateral"), "contact_y", "pad_z"),
    ],
)
def test_lateral_objectives_are_outboard_positive_on_each_wheel(ref, ref_obj, names, yname, xname):
    # reference: ISO 8855 (y to the left) and docs/knc.md ("outboard positive": y_out = y
    # on the left wheel, -y on the right). The raw y slopes of the two wheels of the
    # mirrored axle have opposite signs; mapped outboard they agree with the objective.
    par_name, sgl_name = names
    par = ref["parallel"]
    dy = [central_difference(par, yname, xname, w) for w in (0, 1)]  # ISO, m/m
    assert np.sign(dy[0]) == -np.sign(dy[1]) != 0
    out = [dy[0] * OUTBOARD[0], dy[1] * OUTBOARD[1]]
    assert abs(ref_obj[par_name]) > 1e-3, f"{par_name} vanishes: the outboard sign is lost"
    assert np.sign(ref_obj[par_name]) == np.sign(out[0]) == np.sign(out[1])
    assert ref_obj[par_name] == pytest.approx(np.mean(out), rel=0.05)
    # single wheel travel: the moving left wheel, outboard = +y
    dy_sgl = central_difference(ref["single"], yname, xname, 0)
    assert abs(ref_obj[sgl_name]) > 1e-3
    assert np.sign(ref_obj[sgl_name]) == np.sign(dy_sgl)


def test_hub_moves_inboard_in_bump_on_the_reference_axle(ref, ref_obj):
    # reference: the raw wheel-centre y of each wheel between -8 and +8 mm of parallel
    # travel: the left hub (y > 0) loses y, the right (y < 0) gains it, both inboard;
    # hence par_hub_lateral < 0 with the outboard-positive convention
    par = ref["parallel"]
    c = par.static_index
    y = par.mean_branch("wheel_centre_y")[0]
    assert y[c, 0] > 0 > y[c, 1]  # left wheel on +y (ISO 8855)
    assert y[c + HALF, 0] < y[c - HALF, 0] and y[c + HALF, 1] > y[c - HALF, 1]
    assert ref_obj["par_hub_lateral"] < 0 and ref_obj["sgl_hub_lateral"] < 0


def spin_axis(toe: float, camber: float, wheel: int) -> np.ndarray:
    """Outboard unit spin axis of a wheel from its toe and camber [rad] by the documented
    conventions: toe-in turns the front of the wheel inboard, so the outboard axis points
    forward (+x) on both wheels; negative camber tips the top inboard, so it points up."""
    return np.array(
        [
            np.sin(toe) * np.cos(camber),
            OUTBOARD[wheel] * np.cos(toe) * np.cos(camber),
            -np.sin(camber),
        ]
    )


def test_toe_and_camber_changes_follow_the_knuckle_rotation(ref):
    # reference: geometry of the knuckle's rotation between the static state and +-8 mm
    # (solver states, scipy Rotation, ISO 8855). First order: a rotation about +z turns
    # the left wheel's front to +y (outboard: toe-out) and the right wheel's to +y
    # (inboard: toe-in), so toe-in change ~ -side * w_z; a rotation about +x tips the top
    # of the left wheel to -y (inboard) and of the right one to -y (outboard), so camber
    # change ~ -side * w_x. Exactly: the static spin axis built from the toe and camber
    # channels by the documented conventions, rotated with the knuckle, must give the
    # toe and camber channels at the new position (a flipped convention fails both).
    for test in TESTS:
        res = ref[test]
        g0 = res.static_index
        k0 = int(np.flatnonzero(res.path == g0)[0])
        for g in (g0 - HALF, g0 + HALF):
            k = int(np.flatnonzero(res.path == g)[0])
            R0, R = res.states[k0].R[0, :, 1], res.states[k].R[0, :, 1]  # knuckle (2, 3, 3)
            for w in (0, 1):
                if test == "single" and w == 1:
                    continue  # the right wheel hardly moves
                rel = R[w] @ R0[w].T
                rot = Rotation.from_matrix(rel).as_rotvec()
                toe0, cam0 = res.channels["toe"][0, k0, w], res.channels["camber"][0, k0, w]
                toe, cam = res.channels["toe"][0, k, w], res.channels["camber"][0, k, w]
                where = (test, int(g), w)
                assert abs(toe - toe0) > 1e-4 and abs(cam - cam0) > 1e-4, where  # rad
                # first order (the static camber couples the knuckle's pitch into the
                # heading by ~5 %, hence the loose tolerance)
                assert toe - toe0 == pytest.approx(-OUTBOARD[w] * rot[2], rel=0.1), where
                assert cam - cam0 == pytest.approx(-OUTBOARD[w] * rot[0], rel=0.1), where
                # exact
                s = rel @ spin_axis(toe0, cam0, w)
                assert toe == pytest.approx(np.arctan2(s[0], OUTBOARD[w] * s[1]), abs=1e-9)
                assert cam == pytest.approx(-np.arcsin(s[2]), abs=1e-9), where


def test_camber_sign_matches_the_contact_point_offset(ref):
    # reference: geometry. With negative camber (top of the wheel inboard) the contact
    # point lies outboard of the wheel centre: sin(-camber) = (contact - centre) . y_out
    # / |contact - centre| (exact for zero toe; the reference's 0.04 deg is negligible)
    for test in TESTS:
        res = ref[test]
        d = np.stack(
            [res.channels[f"contact_{a}"] - res.channels[f"wheel_centre_{a}"] for a in "xyz"],
            axis=-1,
        )[0]  # (P, 2, 3)
        s = d[..., 1] * OUTBOARD / np.linalg.norm(d, axis=-1)
        assert np.allclose(res.channels["camber"][0], -np.arcsin(s), atol=1e-6), test
        assert (res.channels["camber"][0] < 0).all()


def test_roll_angle_is_positive_when_the_left_wheel_rises(ref):
    # reference: docs/knc.md and the rig's definition: opposite travel is left pad +s,
    # right pad -s; phi = atan((z_wL - z_wR) / t) rises with s
    cv = curves(ref["opposite"], "down")
    s = ref["opposite"].grid
    assert (np.diff(cv["roll"]) * np.sign(np.diff(s)) > 0).all()
    assert cv["roll"][-1] > 1.0  # deg at +40 mm
    assert cv["wheel"][-1, 0] > 20 and cv["wheel"][-1, 1] < -20  # mm (the tyres take the rest)


def test_single_wheel_travel_drives_the_left_pad_only(ref):
    # reference: the rig's definition (suspenv.rigs.knc): single = left pad +s, right pad
    # at its static height; the objectives then use the moving (left) wheel
    res = ref["single"]
    c = res.static_index
    for br in BRANCHES:
        pad = res.branch("pad_z", br)[0]
        zw = res.branch("wheel_centre_z", br)[0]
        assert np.allclose(pad[:, 0] - pad[c, 0], res.grid, atol=1e-12)
        assert np.allclose(pad[:, 1], pad[c, 1], atol=1e-12)
        travel = zw - zw[c]
        assert travel[-1, 0] > 0.7 * res.grid[-1]  # the left wheel follows its pad
        assert abs(travel[-1, 1]) < 0.1 * res.grid[-1]  # the right wheel barely moves


def test_compliance_forces_act_along_plus_y_and_plus_x_on_both_wheels(ref):
    # reference: the rig's definition (suspenv.rigs.knc): lateral +F along +y, longitudinal
    # +F along +x on both contact points; each wheel centre follows its force
    for test, axis in (("lateral", "y"), ("longitudinal", "x")):
        res = ref[test]
        m = res.mean_branch(f"wheel_centre_{axis}")[0]
        assert (m[-1] > m[0]).all(), test


# ------------------------------------------------------------------ left / right


def test_parallel_and_opposite_objectives_are_the_mean_of_left_and_right(car, car_obj):
    # reference: docs/knc.md ("parallel and opposite travel average the left and right
    # wheels, each against its own travel"); the per-wheel numbers computed here from the
    # raw channels of a car with left/right tolerances. A left-only (or right-only)
    # implementation is off by half the left/right difference.
    per_wheel_names = [
        n for n, d in DEFINITIONS.items() if d[0] != "single" and d[1] not in AXLE_CURVES
    ]
    assert len(per_wheel_names) == 22
    bad = []
    for name in per_wheel_names:
        left, right = per_wheel(car, name)
        scale = max(abs(left), abs(right))
        assert abs(left - right) > 0.01 * scale, f"{name}: the car's sides do not differ"
        got = car_obj[name]
        if not _close(got, 0.5 * (left + right), rtol=1e-7, atol=1e-9):
            bad.append(f"{name}: {got:.7g}, left {left:.7g}, right {right:.7g}")
        elif min(abs(got - left), abs(got - right)) < 0.4 * abs(left - right):
            bad.append(f"{name}: {got:.7g} is one wheel's value")
    assert not bad, "not the left/right mean:\n" + "\n".join(bad)


def test_single_wheel_objectives_use_the_moving_left_wheel(car, car_obj):
    # reference: docs/knc.md ("single wheel travel uses the moving (left) wheel"),
    # computed here from the raw channels; the right wheel's curves of the same test give
    # other numbers (against wheel travel) or none at all (its pad does not move)
    names = [n for n, d in DEFINITIONS.items() if d[0] == "single"]
    assert len(names) == 14
    bad = []
    for name in names:
        left = documented(car, name)
        if not _close(car_obj[name], left, rtol=1e-7, atol=1e-9):
            bad.append(f"{name}: {car_obj[name]:.7g}, left wheel {left:.7g}")
        if DEFINITIONS[name][2] == "wheel":
            right = per_wheel(car, name, wheels=(1,))[1]
            if abs(right - left) < 0.02 * abs(left):
                bad.append(f"{name}: left {left:.7g} and right {right:.7g} do not differ")
    assert not bad, "\n".join(bad)


def test_axle_objectives_of_opposite_travel_see_the_asymmetry(ref_obj, car_obj):
    # reference: docs/knc.md: the rate gradients of the antisymmetric opposite-travel
    # curves vanish for a left/right symmetric axle and become non-zero through
    # asymmetry and hysteresis (the test car has both)
    assert abs(ref_obj["opp_roll_force"]) < 1e-3  # N/mm^2: solver noise
    assert abs(ref_obj["opp_roll_rate"]) < 0.05  # N*m/deg^2
    assert abs(car_obj["opp_roll_force"]) > 1e-2
    assert abs(car_obj["opp_roll_rate"]) > 1.0


# ------------------------------------------------------------------ variation

#: smallest spread that counts as variation, per unit: far above the solver's noise
#: (a mirrored axle gives opp_roll_force ~1e-5 N/mm^2 and opp_roll_rate ~3e-3 N*m/deg^2
#: where the exact value is 0), far below the DoE's spreads
SPREAD_FLOOR = {
    "deg": 1e-4,
    "deg/mm": 1e-5,
    "deg/deg": 1e-4,
    "mm/mm": 1e-4,
    "N/mm": 0.05,
    "N/mm^2": 1e-3,
    "N*m/deg": 1.0,
    "N*m/deg^2": 0.05,
}


def _flat(F: np.ndarray) -> list[str]:
    """Objectives whose spread over the rows of F (n, 40) is within the floor."""
    flat = []
    for j, (name, unit) in enumerate(zip(OBJECTIVE_NAMES, OBJECTIVE_UNITS, strict=True)):
        spread = np.ptp(F[:, j])
        tol = max(SPREAD_FLOOR[unit], 1e-3 * np.abs(F[:, j]).max())
        if not spread > tol:
            flat.append(f"{name}: spread {spread:.3g} {unit} <= {tol:.3g}")
    return flat


def test_every_objective_varies_over_a_design_of_experiments(doe):
    # reference: none (a property): each of the 40 must respond to the hard points,
    # bushings and alignment within the identification bounds (+-5 mm, +-20 %, left and
    # right independent), else it cannot identify anything; a definition that returns a
    # constant (e.g. 0) fails here
    F = objectives(doe[0])
    assert F.shape == (10, 40) and np.isfinite(F).all()
    flat = _flat(F)
    assert not flat, "objectives that do not vary over the DoE:\n" + "\n".join(flat)


#: docs/knc.md: zero for a left/right symmetric model (antisymmetric opposite-travel curves)
ZERO_BY_SYMMETRY = {"opp_roll_force", "opp_roll_rate"}


def test_on_symmetric_designs_only_the_two_antisymmetric_rate_gradients_stay_flat(doe):
    # reference: docs/knc.md ("the rate gradients of the antisymmetric opposite-travel
    # curves vanish for a left/right symmetric model"). The identification model is
    # symmetric, so these two can never follow its parameters; every other objective
    # must. (A lost outboard sign makes par_hub_lateral 0 for every mirrored axle.)
    F = objectives(doe[1])
    assert np.isfinite(F).all()
    flat = {line.split(":")[0] for line in _flat(F)}
    assert flat == ZERO_BY_SYMMETRY, "\n".join(_flat(F))
