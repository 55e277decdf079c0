"""The K&C sheet: compliance numbers against an independent linear solve, the report on
channel sets without contact-patch positions, and the delta-method interval."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.metrics.knc_report import (
    compliance_report,
    knc_report,
    report_needs,
)
from suspenv.models.mcpherson import build_axle, reference_design
from suspenv.rigs.knc import run_tests


@pytest.fixture(scope="module")
def ref_results():
    axle = build_axle(reference_design()[None])
    return run_tests(
        axle, ("parallel", "opposite", "steering", "lateral", "longitudinal", "aligning")
    )


#: rig test -> (load of compliance_matrix_full, sign of the other wheel's load in its own
#: sense relative to this wheel's, sign of the sheet's load relative to the matrix's)
_RIG_LOADS = {
    "lateral": ("Fy", -1.0, 1.0),
    "aligning": ("Mz", -1.0, 1.0),
    "longitudinal": ("Fx", 1.0, -1.0),
}


@pytest.mark.parametrize("test", sorted(_RIG_LOADS))
def test_compliance_slopes_match_the_linearised_compliance_matrix(ref_results, test):
    """Reference: :func:`suspenv.metrics.knc.compliance_matrix_full`, the solver's linear
    solve at the static position (a unit load on one wheel alone, no rig loop). The rig
    loads both wheels at once, so a wheel's slope is its direct term plus the other
    wheel's cross term times that wheel's load in its own sense (lateral and aligning:
    the ISO-equal loads are opposite in the wheels' own senses; braking: equal). The
    quadratic fit over +-3 grid points (+-500 N, +-50 N m) truncates the curvature: 1 %."""
    from suspenv.metrics.knc import (
        FULL_COMPLIANCE_LOADS,
        FULL_COMPLIANCE_OUTPUTS,
        compliance_matrix_full,
    )

    rep = compliance_report(ref_results)
    C, _ = compliance_matrix_full(build_axle(reference_design()[None]))
    load, other, sheet_sign = _RIG_LOADS[test]
    k = FULL_COMPLIANCE_LOADS.index(load)
    for suffix, out in (
        ("steer", "toe"),
        ("camber", "camber"),
        ("wc_x", "wheel_centre_x"),
        ("wc_y", "wheel_centre_y"),
    ):
        o = FULL_COMPLIANCE_OUTPUTS.index(out)
        want = [sheet_sign * (C[0, i, o, k, i] + other * C[0, i, o, k, 1 - i]) for i in (0, 1)]
        got = rep[f"{test}_compliance_{suffix}"][0]
        scale = np.abs(want).max() + 1e-6
        np.testing.assert_allclose(got, want, rtol=0.01, atol=0.01 * scale)


def test_report_without_contact_patch_channels_says_what_is_missing(ref_results):
    full = knc_report(ref_results)
    cut = {}
    for t, r in ref_results.items():
        chans = {
            k: v
            for k, v in r.channels.items()
            if k not in ("contact_x", "contact_y", "contact_z", "scrub_radius", "trail")
        }
        cut[t] = type(r)(r.test, r.grid, r.path, chans, r.ok, r.messages)
    rep = knc_report(cut)  # no KeyError
    needs = report_needs(cut)
    assert "scrub_radius" in needs and "channel parallel:scrub_radius" in needs["scrub_radius"]
    assert "roll_rate" in needs and "contact_y" in needs["roll_rate"]
    for name, v in rep.items():
        if name in needs:
            assert not np.all(np.isfinite(v))
        else:  # every number the channels allow is the full report's
            np.testing.assert_allclose(v, full[name], rtol=1e-12, atol=1e-12)


def test_ackermann_percentage_is_0_for_parallel_and_100_for_the_ackermann_pair():
    """Golden: the definition's two anchors (closed form of the Ackermann pair:
    inner = atan(L tan d_o / (L - t tan d_o))); half-way angles give 50 %."""
    from suspenv.metrics.knc_report import ackermann_pct
    from suspenv.rigs.knc import KCResult, loop_path

    def fake(dl: np.ndarray, dr: np.ndarray) -> KCResult:
        steps = dl.size - 1
        path = loop_path(steps)
        toe = np.stack([-dl, dr], axis=-1)[path]  # toe-in = -delta (left), +delta (right)
        grid = np.linspace(-0.03, 0.03, steps + 1)
        return KCResult(
            "steering", grid, path, {"toe": np.deg2rad(toe)[None]}, np.ones(1, bool), [""]
        )

    L, t = 2600.0, 1400.0
    do = np.deg2rad(np.linspace(0.0, 15.0, 6))
    di = np.rad2deg(np.arctan(L * np.tan(do) / (L - t * np.tan(do))))
    do = np.rad2deg(do)
    tr = np.array([t])
    par = np.r_[-do[::-1], do[1:]]
    assert ackermann_pct(fake(par, par), "down", L, tr)[0] == pytest.approx(0.0, abs=1e-9)
    pair = fake(np.r_[-do[::-1], di[1:]], np.r_[-di[::-1], do[1:]])
    assert ackermann_pct(pair, "down", L, tr)[0] == pytest.approx(100.0, abs=1e-9)
    mid = 0.5 * (di + do)
    half = fake(np.r_[-do[::-1], mid[1:]], np.r_[-mid[::-1], do[1:]])
    assert ackermann_pct(half, "down", L, tr)[0] == pytest.approx(50.0, abs=1e-9)


def test_suspenv_knc_prints_the_sheet_of_a_rig_channel_set(capsys):
    """A measurement with what rigs record (no contact-patch position, scrub radius,
    trail or knuckle pitch) gets the sheet's numbers its channels allow and says what
    the others need (no KeyError)."""
    import dataclasses

    from suspenv.cli.knc import print_measured_sheet
    from suspenv.methods.curves.identify import measure_test_car

    m, _ = measure_test_car(0, ("noise",), tests=("parallel", "opposite", "lateral"))
    drop = {"contact_x", "contact_y", "contact_z", "scrub_radius", "trail", "knuckle_pitch"}
    tests = {
        t: dataclasses.replace(mt, channels={k: v for k, v in mt.channels.items() if k not in drop})
        for t, mt in m.tests.items()
    }
    print_measured_sheet(dataclasses.replace(m, tests=tests))
    out = capsys.readouterr().out
    assert "bump_steer" in out and "lateral_compliance_steer" in out
    assert "scrub_radius" in out and "needs: channel parallel:scrub_radius" in out
    assert "roll_rate" in out and "opposite:contact_y" in out
    assert "steer_ratio" in out and "needs: the steering test" in out
    # an axle number has one value: "(axle)" in the right wheel's column, as in the
    # simulated report (one printer)
    rows = {line.split()[0]: line.split() for line in out.splitlines()[2:] if line.strip()}
    assert rows["roll_centre_height"][2] == "(axle)" and rows["bump_steer"][2] != "(axle)"


def test_loop_half_width_matches_the_strut_friction_hand_calculation():
    """Reference: hand calculation (as tests/test_knc_effects.py). A saturated friction
    force f between rod and tube reverses between the branches (2 f along the strut);
    through the motion ratio MR it reaches the wheel, which shares it between the tyre
    (k_t) and the suspension (wheel rate k_w): the wheel load's half-width is
    f MR k_t / (k_t + k_w). Without friction there is no loop."""
    from suspenv.metrics.knc import objectives_subset
    from suspenv.metrics.knc_report import loop_half_width
    from suspenv.models.mcpherson import AxleSolver
    from suspenv.models.mcpherson.effects import axle_effect

    axle = build_axle(reference_design()[None])
    f = 100.0
    eff = [axle_effect("coulomb_friction", "strut", f_c=f, sigma=5e6)]
    res = run_tests(axle, ("parallel",), steps=10, effects=eff)["parallel"]
    plain = run_tests(axle, ("parallel",), steps=10)
    k_w = objectives_subset(plain, ("par_susp_ride_rate_pos",))[0, 0]
    k_t = axle.constants.tyre_rate
    mr = AxleSolver(axle).motion_ratio_kinematic[0, 0]
    hand = f * mr * k_t / (k_t + k_w)
    assert loop_half_width(res, "tyre_fz")[0, 0] == pytest.approx(hand, rel=0.03)
    assert np.abs(loop_half_width(plain["parallel"], "tyre_fz")).max() < 0.025


def test_rows_solved_apart_keep_their_static_hard_points():
    """Designs with other fitted constants are solved apart and stacked
    (:func:`suspenv.methods.curves.curve_fit._concat`); the geometric roll centre reads their
    static hard points, which must survive the stacking (lost, the sheet's gradient of
    it was NaN and its interval zero). Reference: the same designs solved together, to
    the solver's tolerance (1 nm)."""
    from suspenv.methods.curves.curve_fit import _concat
    from suspenv.metrics.knc_report import geometric_roll_centre

    X = np.stack([reference_design(), reference_design()])
    X[1, 2] += 0.004  # lower ball joint 4 mm higher
    both = run_tests(build_axle(X), ("parallel",))["parallel"]
    apart = [run_tests(build_axle(X[[i]]), ("parallel",))["parallel"] for i in (1, 0)]
    got = _concat(apart, np.array([1, 0]))
    assert set(got.static_points) == set(both.static_points)
    for name, v in both.static_points.items():
        np.testing.assert_allclose(got.static_points[name], v, rtol=0, atol=1e-9)
    h = geometric_roll_centre(got)[1]
    np.testing.assert_allclose(h, geometric_roll_centre(both)[1], rtol=0, atol=1e-6)
    assert h[0] != h[1]


def test_sandwich_interval_uses_students_t_of_its_loop_count():
    """A cluster-robust variance from G loop scores has G - 1 degrees of freedom: its
    95 % half-width is sqrt(G / (G - 1)) t_0.975(G - 1) standard errors. Reference:
    Student's t table (t_0.975 = 2.365 for 7, 2.262 for 9 degrees of freedom, to the
    table's 3 decimals); it tends to the normal 1.960 for many loops and is wider for
    fewer loops (a test held out of the fit)."""
    from suspenv.methods.curves.knc_sheet import Z95, sandwich_quantile

    assert sandwich_quantile(8) == pytest.approx(np.sqrt(8 / 7) * 2.365, abs=1e-3)
    assert sandwich_quantile(10) == pytest.approx(np.sqrt(10 / 9) * 2.262, abs=1e-3)
    assert sandwich_quantile(10**6) == pytest.approx(Z95, abs=1e-5)
    assert sandwich_quantile(8) > sandwich_quantile(10) > Z95


def test_a_gradient_a_design_cannot_give_leaves_the_interval_unknown():
    # reference: a half-width is sqrt(g' C g); with a component of g unknown (NaN) the
    # product is unknown, so the interval must say so rather than shrink to zero
    from suspenv.methods.curves.knc_sheet import _half_widths

    cov = np.eye(2)
    g = np.array([[1.0, np.nan], [0.0, 2.0]])
    gd = g[:, 1] - g[:, 0]
    for covs in (((cov, 1.96), (2 * cov, 2.5)), ((2 * cov, 2.5), (cov, 1.96))):
        hw, hw_d = _half_widths(g, gd, covs)
        assert np.isfinite(hw[0]) and np.isnan(hw[1]) and np.isnan(hw_d)
