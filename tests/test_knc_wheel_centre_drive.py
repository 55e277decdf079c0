"""The rig's wheel-centre travel drive and the channel sets real rigs record.

A K&C rig in wheel-centre travel control moves each pad until its wheel centre is at
the commanded travel; rigs record wheel angles, wheel-centre displacements and wheel
loads, not contact-patch positions. References, each independent of the drive's
bordered Newton step (``solver._CentreDrive``):

* the definition of the drive: the wheel centres are at the stroke (to round-off, the
  height is one of the solver's unknowns), a held pad does not move;
* the pad-driven solver: at the pad heights the wheel-centre drive found, a pad-driven
  Newton solve keeps the state (to the solver tolerance, 1e-6 m / 1e-5 rad);
* the pad-driven rig: its wheel-centre height against pad stroke, interpolated at the
  wheel-centre grid (cubic interpolation of a smooth curve on 2 mm steps), gives the
  same pads and toe;
* the loader and ``identify``: a measurement of the noise-free reference car with a
  real rig's channel set and ``travel_drive = "wheel_centre"`` round-trips through the
  file format and its fit residual at the truth is zero (the data are the rig's own),
  while the same data read as pad-driven are not.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from suspenv.core.errors import ValidationError
from suspenv.measurements.knc_file import from_results, load_measurement, write_measurement
from suspenv.methods.curves.identify import build_model, resolve_vehicle
from suspenv.models.mcpherson import AxleSolver, build_axle, reference_design
from suspenv.rigs.knc import TESTS, run_tests

SIGN = {"parallel": (1.0, 1.0), "opposite": (1.0, -1.0), "single": (1.0, 0.0)}
#: what rigs record (no contact-patch x/y): wheel angles, wheel-centre positions, loads
RIG_CHANNELS = ("toe", "camber", "wheel_centre_x", "wheel_centre_y", "wheel_centre_z", "tyre_fz")
STEPS = 20


@pytest.fixture(scope="module")
def axle():
    return build_axle(reference_design()[None, :])


@pytest.fixture(scope="module")
def centre_runs(axle):
    res = run_tests(axle, TESTS, steps=STEPS, travel_drive="wheel_centre", keep_states=True)
    for r in res.values():
        assert r.ok.all(), r.messages
    return res


def test_wheel_centres_follow_the_stroke_and_a_held_pad_stays(centre_runs):
    for test, r in centre_runs.items():
        z = r.channels["wheel_centre_z"][0]  # (P, 2)
        s = r.grid[r.path]
        for w in (0, 1):
            if SIGN[test][w]:
                # round-off: the height is an unknown, set by the last Newton step
                assert np.abs(z[:, w] - z[0, w] - SIGN[test][w] * s).max() < 1e-12, test
            else:
                assert np.ptp(r.channels["pad_z"][0][:, w]) == 0.0, test
        # the pads had to move further than the wheel centres (the tyre deflects)
        pad = r.channels["pad_z"][0][:, 0]
        assert np.ptp(pad) > 1.05 * np.ptp(z[:, 0])


def test_each_state_is_the_pad_driven_equilibrium_at_the_pads_found(axle, centre_runs):
    solver = AxleSolver(axle)
    for r in centre_runs.values():
        for k in (2, 7, 15, 30):
            st, pads = r.states[k], r.channels["pad_z"][0][k][None]
            again, conv, _ = solver.solve(st, pads)
            assert conv.all()
            out = solver.outputs(again, pads)
            for ch, tol in (("wheel_centre_z", 1e-6), ("toe", 1e-5), ("camber", 1e-5)):
                assert np.abs(out[ch][0] - r.channels[ch][0][k]).max() < tol, (r.test, k, ch)


def test_the_pad_driven_rig_interpolated_at_the_wheel_centre_grid_agrees(axle, centre_runs):
    # parallel travel: both wheels alike; the pad run's wheel-centre travel against pad
    # stroke on a wider stroke, inverted by a cubic spline
    pad = run_tests(axle, ("parallel",), amplitude=0.055, steps=44)["parallel"]
    wc = centre_runs["parallel"]
    zp = pad.mean_branch("wheel_centre_z")[0, :, 0]
    zp = zp - zp[pad.static_index]
    stroke_at = CubicSpline(zp, pad.grid)  # pad stroke at a wheel-centre travel
    toe_at = CubicSpline(zp, pad.mean_branch("toe")[0, :, 0])
    pads = wc.mean_branch("pad_z")[0, :, 0]
    got_stroke = pads - pads[wc.static_index]
    assert np.allclose(got_stroke, stroke_at(wc.grid), rtol=0, atol=2e-6)  # m
    assert np.allclose(wc.mean_branch("toe")[0, :, 0], toe_at(wc.grid), rtol=0, atol=2e-6)


def test_unknown_travel_drive_is_refused(axle):
    with pytest.raises(ValidationError, match="travel_drive"):
        run_tests(axle, ("parallel",), steps=4, travel_drive="wheel")


def test_identify_takes_a_real_rigs_wheel_centre_driven_channel_set(centre_runs, tmp_path):
    results = {t: centre_runs[t] for t in TESTS}
    m = from_results(results, "reference", travel_drive="wheel_centre")
    for mt in m.tests.values():  # what a rig records: no contact-patch channels
        mt.channels = {c: v for c, v in mt.channels.items() if c in RIG_CHANNELS}
    write_measurement(m, tmp_path)
    back = load_measurement(tmp_path)
    assert back.meta["travel_drive"] == "wheel_centre"
    assert back.channels == sorted(RIG_CHANNELS)
    sigma = {c: 1e-5 for c in back.channels}
    sigma["tyre_fz"] = 1.0
    back.noise = sigma
    free = ["static_toe", "tie_rod_inner_z"]
    x = reference_design()
    model = build_model(back, resolve_vehicle(None), x, free)
    u = model.unit(x)
    R, ok, _ = model.residuals(u[None])
    assert ok[0] and np.abs(R[0]).max() < 0.2  # noise units: the data are the rig's own
    back.meta["travel_drive"] = "pad"  # the same data read as pad-driven do not fit
    wrong = build_model(back, resolve_vehicle(None), x, free)
    Rw, ok_w, _ = wrong.residuals(u[None])
    assert ok_w[0] and np.abs(Rw[0]).max() > 50
