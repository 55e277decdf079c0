"""K&C compliance tests (lateral and longitudinal force at the contact points)."""

from __future__ import annotations

from dataclasses import replace

import mcpherson_reference as reference
import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
from suspenv.rigs.knc import run_tests, wheel_loads

STEPS = 8
FORCE = 2000.0  # N


@pytest.fixture(scope="module")
def axle():
    return build_axle(reference_design()[None, :])


#: the contact-point force tests (traction, aligning: tests/test_knc_rig_tests.py)
CONTACT = ("lateral", "longitudinal")


@pytest.fixture(scope="module")
def plain_runs(axle):
    return run_tests(axle, CONTACT, steps=STEPS, keep_states=True, force_amplitude=FORCE)


def test_every_body_is_in_balance_under_the_contact_loads(axle, plain_runs):
    # reference: statics of each rigid body (sum F = 0, sum p x F + M = 0 about the
    # origin) from the element loads re-evaluated at every converged step, the applied
    # contact-point force included
    solver = AxleSolver(axle)
    for test, res in plain_runs.items():
        assert res.ok.all(), res.messages
        assert res.unit == "N" and res.grid[-1] == FORCE
        for k, st in enumerate(res.states):
            ext = np.broadcast_to(wheel_loads(test, res.grid[res.path[k]])[:, :6], (1, 2, 6))
            F, M = reference.body_loads(solver, st, solver.pad_static, ext)
            assert np.abs(F).max() < 0.05, (test, k)  # N, against kN loads
            assert np.abs(M).max() < 0.05, (test, k)  # N*m


def test_mirror_symmetry_of_the_lateral_and_longitudinal_tests(plain_runs):
    # reference: mirror symmetry y -> -y of a symmetric axle. A +y force on both wheels
    # mirrors to a -y force, so the left wheel at +F is the right wheel at -F (toe,
    # camber and wheel load are defined per side; contact y changes sign). A force
    # along x mirrors to itself: the two wheels move alike at every step.
    lat = plain_runs["lateral"]
    for ch, sign in (("toe", 1.0), ("camber", 1.0), ("tyre_fz", 1.0), ("contact_y", -1.0)):
        mid = lat.mean_branch(ch)[0]  # (steps + 1, 2) on the force grid
        assert np.allclose(mid[:, 0], sign * mid[::-1, 1], rtol=1e-6, atol=1e-9), ch
    lon = plain_runs["longitudinal"]
    for ch, sign in (("toe", 1.0), ("camber", 1.0), ("tyre_fz", 1.0), ("contact_y", -1.0)):
        v = lon.channels[ch][0]
        assert np.allclose(v[:, 0], sign * v[:, 1], rtol=1e-6, atol=1e-9), ch


def test_small_force_slope_matches_a_direct_loaded_solve(axle):
    # reference: an independent Newton solve from the static state with the load applied
    # in one go (no continuation along the loop); the rig's first step must agree
    res = run_tests(axle, ("lateral",), steps=2, force_amplitude=100.0)["lateral"]
    solver = AxleSolver(axle)
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    loaded, conv2, _ = solver.solve(
        st, solver.pad_static, wheel_loads("lateral", 100.0)[None, :, :6]
    )
    assert conv.all() and conv2.all()
    out = solver.outputs(loaded, solver.pad_static)
    k = int(np.flatnonzero(res.grid[res.path] == 100.0)[0])
    for ch in ("toe", "camber", "contact_y"):
        assert np.allclose(res.channels[ch][0, k], out[ch][0], atol=1e-9), ch


def test_the_applied_force_does_no_net_work_on_an_elastic_axle_and_positive_work_with_hysteresis(
    axle,
):
    # reference: energy balance over a closed load loop. The work of the applied force,
    # W = sum F_mid * dx (contact point along the force), is zero for elastic elements
    # (the loop retraces itself) and equals the energy the Dahl elements dissipate
    # (W > 0) when the lower-arm bushes have hysteresis
    eff = [axle_effect("dahl_hysteresis", "lower_arm", f_c=150.0, sigma_ratio=1.0)]

    def work(effects):
        res = run_tests(
            axle, ("longitudinal",), steps=STEPS, effects=effects, force_amplitude=FORCE
        )
        r = res["longitudinal"]
        f = r.grid[r.path]
        x = r.channels["contact_x"][0]  # (P, 2)
        return (0.5 * (f[1:] + f[:-1])[:, None] * np.diff(x, axis=0)).sum(axis=0)

    plain = work([])
    loop = work(eff)
    assert np.abs(plain).max() < 1e-6  # J
    assert (loop > 0.01).all(), loop  # J: a visible loop on both wheels


def test_unknown_test_and_bad_force_amplitude_are_rejected(axle):
    with pytest.raises(ValidationError, match="unknown K&C test 'twist'"):
        run_tests(axle, ("twist",))
    with pytest.raises(ValidationError, match="force_amplitude > 0"):
        run_tests(axle, ("lateral",), force_amplitude=-5.0)


def test_compliance_slopes_match_the_linearised_compliance_matrix(axle):
    # reference: the compliance matrix of the linearised equilibrium (inverse Jacobian,
    # suspenv.metrics.knc.compliance_matrix) with the load on the left wheel alone; the
    # right wheel's load reaches the left only through the anti-roll bar, which resists
    # the one-sided jacking of a single loaded wheel (2.4 % in longitudinal camber), and
    # through the rack, held rigid here (a compliant one carries the right tie rod's
    # force to the left wheel: tests/test_knc_steering_compliance.py)
    from suspenv.cli.knc import compliance_slopes
    from suspenv.metrics.knc import compliance_matrix

    axle = replace(axle, rack_compliance=np.zeros(axle.n))

    C, labels = compliance_matrix(axle)
    res = run_tests(axle, CONTACT, steps=10, force_amplitude=500.0)
    for test, load in (("lateral", "Fy"), ("longitudinal", "Fx")):
        j = labels["loads"].index(load)
        slopes = compliance_slopes(res[test])
        for name in ("toe", "camber"):
            i = labels["outputs"].index(name)
            assert slopes[f"d{name} [deg/kN]"] == pytest.approx(C[0, 0, i, j], rel=0.03), (
                test,
                name,
            )


def test_cli_runs_a_compliance_test(tmp_path):
    import argparse

    from suspenv.cli import knc

    parser = argparse.ArgumentParser()
    knc.register(parser.add_subparsers())
    args = parser.parse_args(
        ["knc", "reference", "--test", "longitudinal", "--steps", "6", "--out", str(tmp_path)]
    )
    assert args.func(args) == 0
    lines = (tmp_path / "mcpherson_reference_longitudinal.csv").read_text().splitlines()
    assert lines[0].startswith("step,branch,force [N],") and len(lines) == 1 + 13
    assert float(lines[4].split(",")[2]) == 2500.0  # design -> +F -> -F -> design


def test_cli_test_choices_are_the_rig_tests():
    # the CLI lists the tests without importing the solver; the rig is the reference
    from suspenv.cli.knc import TEST_CHOICES
    from suspenv.rigs.knc import RIG_TESTS

    assert tuple(TEST_CHOICES) == tuple(RIG_TESTS)
