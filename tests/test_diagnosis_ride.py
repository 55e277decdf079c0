"""Ride diagnosis of the minibus: generator, model adapter, planted concealed effects."""

from __future__ import annotations

import json

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.ride import (
    MinibusRideAdapter,
    diagnose_ride,
    make_ride_case,
    pulse_inputs_recording,
    ride_effect,
    write_ride_case,
    write_ride_report,
)
from suspenv.diagnosis.ride.model import SEAT_MASS, seat_mount_response
from suspenv.models.minibus import STUDY_PICK
from suspenv.recordings import load_recording
from suspenv.rigs.ride import PulseBump, pulse_run

PICK = {"C1": 1.12, "C2": 0.88, "T1": 8.8e4, "K1": 73.5}


def test_adapter_matches_the_pulse_rig_at_a_finer_step():
    # independent path: the rig's own pulse inputs (exact half-step profile) at 1 kHz vs
    # the adapter on the 200 Hz recording (interpolated midpoints): peaks agree to 5 %
    m = MinibusRideAdapter()
    th = m.theta_from(PICK)
    for v in (20.0, 50.0):
        rec = pulse_inputs_recording(v)
        p = m.simulate(th, rec)
        ref = pulse_run(STUDY_PICK[None, :], "no_load",
                        PulseBump(speed_kmh=v, lead_in=0.3, duration_s=rec.duration,
                                  sample_rate=1000.0))  # fmt: skip
        assert np.max(np.abs(p["acc_front"])) == pytest.approx(ref.peak_front[0], rel=0.05)
        assert np.max(np.abs(p["acc_rear"])) == pytest.approx(ref.peak_rear[0], rel=0.05)


def test_seat_mount_filter_matches_closed_form_transmissibility():
    # closed form: base-excited mass-spring-damper, |H| = sqrt((k^2 + (c w)^2) /
    # ((k - m w^2)^2 + (c w)^2)), checked on a steady sine below and near resonance
    k, c = SEAT_MASS * (2 * np.pi * 7.0) ** 2, 800.0
    dt = 1 / 200.0
    t = np.arange(0, 20.0, dt)
    for f in (2.0, 7.0):
        w = 2 * np.pi * f
        a = np.sin(w * t)
        y = seat_mount_response(a, dt, k, c)
        amp = np.sqrt(2 * np.mean(y[len(t) // 2 :] ** 2))
        exact = np.sqrt((k**2 + (c * w) ** 2) / ((k - SEAT_MASS * w**2) ** 2 + (c * w) ** 2))
        assert amp == pytest.approx(exact, rel=0.03)


def test_bump_stop_beyond_the_travel_changes_nothing():
    # physics: a stop whose gap is never reached exerts no force
    m0 = MinibusRideAdapter()
    rec = pulse_inputs_recording(20.0)
    p0 = m0.simulate(m0.theta_from(PICK), rec)
    far = ride_effect("bump_stop", "rear_suspension", gap=0.14, k_stop=1e6)
    m1 = MinibusRideAdapter([far])
    p1 = m1.simulate(m1.theta_from(PICK), rec)
    for ch in p0:
        assert np.allclose(p0[ch], p1[ch], atol=1e-9)


def test_adapter_rejects_unsupported_effects():
    with pytest.raises(ValidationError, match="kind, location"):
        ride_effect("bump_stop", "front_damper")
    from suspenv.models.effects import make_effect

    with pytest.raises(ValidationError, match="kind, location"):
        MinibusRideAdapter([make_effect("cubic_stiffness", location="rear_leaf")])


def test_generator_is_seeded_noisy_and_keeps_the_truth_apart(tmp_path):
    a = make_ride_case(7, "seat_mount", speeds_kmh=(50.0,), random_road=False)
    b = make_ride_case(7, "seat_mount", speeds_kmh=(50.0,), random_road=False)
    c = make_ride_case(8, "seat_mount", speeds_kmh=(50.0,), random_road=False)
    ra, rb, rc = a.fit[0], b.fit[0], c.fit[0]
    assert np.array_equal(ra.outputs["acc_seat"], rb.outputs["acc_seat"])
    assert not np.allclose(ra.outputs["acc_seat"], rc.outputs["acc_seat"])
    # noise level: measured minus the noiseless truth, relative to the channel RMS
    truth = MinibusRideAdapter(a.truth.effects)
    clean = truth.simulate(truth.theta_from(a.truth.base), ra)
    for ch, y in clean.items():
        ratio = np.std(ra.outputs[ch] - y) / np.sqrt(np.mean(y**2))
        assert ratio == pytest.approx(a.truth.noise_fraction, rel=0.2)
    # the recordings say nothing about the concealed effect
    blob = json.dumps([r.meta for r in a.fit + a.heldout]) + " ".join(
        r.name for r in a.fit + a.heldout
    )
    assert "seat_mount" not in blob and "kelvin" not in blob
    paths = write_ride_case(a, tmp_path / "case", tmp_path / "truth")
    assert all(p.is_file() for p in paths)
    assert not any("truth" in p.name for p in paths if p.parent == tmp_path / "case")
    rec = load_recording(paths[0])
    assert np.allclose(rec.outputs["acc_seat"], ra.outputs["acc_seat"])
    with pytest.raises(ValidationError, match="apart"):
        write_ride_case(a, tmp_path / "x", tmp_path / "x")


@pytest.fixture(scope="module")
def bump_stop_diagnosis():
    # planted: a bump stop at a seeded random axle, gap and stiffness; 50 km/h pulses only
    case = make_ride_case(2, "bump_stop", speeds_kmh=(50.0,), random_road=False)
    return case, diagnose_ride(case.fit, case.heldout, screen=1, max_nfev=10)


def test_planted_bump_stop_is_named_with_its_axle(bump_stop_diagnosis):
    case, d = bump_stop_diagnosis
    truth = case.truth.effects[0]
    assert d.named_kinds == [f"bump_stop@{truth.location}"], d.verdict
    assert "bump stop" in d.verdict
    # recovered element parameters vs the concealed ones
    gap = d.final_params[f"{truth.name}.gap"]["value"]
    assert gap == pytest.approx(truth.params["gap"], rel=0.1)
    # held-out repeat run: error falls
    assert d.comparison.heldout_reduction > 0.2
    # the residual lives after the impacts, not before the bump
    before = [s for s in d.location.by_dimension("time window") if s.part == "before the bump"]
    assert before[0].share < 0.05


def test_no_effect_nothing_claimed():
    # planted: no concealed effect at all
    case = make_ride_case(3, None, speeds_kmh=(50.0,), random_road=False)
    d = diagnose_ride(case.fit, case.heldout, screen=1, max_nfev=10)
    assert d.named == [], d.verdict
    assert d.verdict.startswith("no significant missing physics")
    # the baseline recovers the design values (no effect to absorb)
    for k, v in case.truth.base.items():
        assert d.baseline["params"][k]["value"] == pytest.approx(v, rel=0.03)


def test_ride_report_files(bump_stop_diagnosis, tmp_path):
    _, d = bump_stop_diagnosis
    paths = write_ride_report(d, tmp_path)
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths)
    text = (tmp_path / "ride_diagnosis.md").read_text()
    assert "bump stop" in text and "time window" in text


@pytest.mark.slow
@pytest.mark.parametrize(
    ("kind", "expect"),
    [
        ("leaf_friction", "dahl_hysteresis@rear_leaf"),
        ("seat_mount", "kelvin_voigt@seat_mount"),
        ("damper_friction", "coulomb_friction@"),
        ("bump_stop", "bump_stop@"),
    ],
)
def test_full_planted_cases(kind, expect):
    # planted, full protocol: pulses at 20 and 50 km/h, repeat runs and a random road held out
    case = make_ride_case(21, kind)
    d = diagnose_ride(case.fit, case.heldout, screen=3)
    assert d.named and d.named_kinds[0].startswith(expect), d.verdict
    assert d.comparison.heldout_reduction > 0.0


@pytest.mark.slow
def test_full_no_effect_control():
    case = make_ride_case(22, None)
    d = diagnose_ride(case.fit, case.heldout, screen=3)
    assert d.named == [], d.verdict
