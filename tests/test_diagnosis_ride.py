"""Ride diagnosis of the minibus: generator, model adapter, planted concealed effects."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from benchmarks.ride_mismatch import OUT_OF_LIBRARY_KINDS, delay_signal
from benchmarks.ride_truth import make_ride_case, write_ride_case
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.engine import diagnose
from suspenv.diagnosis.ride.family import RideFamily
from suspenv.diagnosis.ride.model import (
    SEAT_MASS,
    MinibusRideAdapter,
    pulse_inputs_recording,
    ride_effect,
    seat_mount_response,
)
from suspenv.diagnosis.ride.residual import (
    noise_floor,
    residual_check,
    white_noise_sd,
)
from suspenv.measurements import load_recording
from suspenv.models.minibus import STUDY_PICK
from suspenv.reports.diagnosis import write_diagnosis_report
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


def test_seat_mount_filter_coefficients_are_scipy_bilinear():
    # second reference: scipy.signal.bilinear of the pre-warped H(s); the written-out
    # coefficients round differently, so lightly damped mounts agree to ~1e-13
    from scipy import signal as sig

    dt, x = 1 / 200.0, np.random.default_rng(0).normal(size=2000)
    for k, c in ((2e4, 50.0), (2.3e5, 900.0), (2e6, 2e4)):
        warp = np.tan(np.sqrt(k / SEAT_MASS) * dt / 2) / (np.sqrt(k / SEAT_MASS) * dt / 2)
        b, a = sig.bilinear([c / warp, k], [SEAT_MASS / warp**2, c / warp, k], 1 / dt)
        ref = sig.lfilter(b, a, x)
        y = seat_mount_response(x, dt, k, c)
        np.testing.assert_allclose(y, ref, rtol=0, atol=1e-11 * np.max(np.abs(ref)))


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
    return case, diagnose(case.fit, RideFamily(screen_count=1, max_nfev=10), holdout=case.heldout)


def test_planted_bump_stop_is_named_with_its_axle(bump_stop_diagnosis):
    case, d = bump_stop_diagnosis
    truth = case.truth.effects[0]
    assert d.named_candidates == [f"bump_stop@{truth.location}"], d.verdict
    assert "bump stop" in d.verdict
    # recovered element parameters vs the concealed ones
    gap = d.final_params[f"{truth.name}.gap"]["value"]
    assert gap == pytest.approx(truth.params["gap"], rel=0.1)
    # held-out repeat run: error falls
    assert d.comparison.heldout_reduction > 0.2
    # the residual lives after the impacts, not before the bump
    before = [s for s in d.location.by_dimension("time window") if s.part == "before the bump"]
    assert before[0].share < 0.05
    # the element is from the library: only white noise is left, the name is confident
    assert d.confident and not d.residual.residual_remains, d.verdict


def test_no_effect_nothing_claimed():
    # planted: no concealed effect at all
    case = make_ride_case(3, None, speeds_kmh=(50.0,), random_road=False)
    d = diagnose(case.fit, RideFamily(screen_count=1, max_nfev=10), holdout=case.heldout)
    assert d.named == [], d.verdict
    assert d.verdict.startswith("no significant missing physics")
    assert not d.residual.residual_remains and not d.confident, d.verdict
    # the baseline recovers the design values (no effect to absorb)
    for k, v in case.truth.base.items():
        assert d.baseline["params"][k]["value"] == pytest.approx(v, rel=0.03)


def test_ride_report_files(bump_stop_diagnosis, tmp_path):
    _, d = bump_stop_diagnosis
    paths = write_diagnosis_report(d, tmp_path)
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths)
    text = (tmp_path / "ride_diagnosis.md").read_text()
    assert "bump stop" in text and "time window" in text and "What is left" in text
    js = json.loads((tmp_path / "ride_diagnosis.json").read_text())
    assert (
        js["confident"] == d.confident
        and "excess_ratio" in js["findings"]["residual_left"]["record"]
    )


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
    d = diagnose(case.fit, RideFamily(screen_count=3), holdout=case.heldout)
    assert d.named and d.named_candidates[0].startswith(expect), d.verdict
    assert d.comparison.heldout_reduction > 0.0


@pytest.mark.slow
def test_full_no_effect_control():
    case = make_ride_case(22, None)
    d = diagnose(case.fit, RideFamily(screen_count=3), holdout=case.heldout)
    assert d.named == [], d.verdict


# ------------------------------------------------------------------ out-of-library truths
def test_delay_signal_matches_a_shifted_sine():
    # closed form: y(t - tau) of a sine that starts at rest; away from the start the
    # band-limited fractional delay equals sin(w (t - tau)) (a 10 Hz ride component)
    dt, tau, f = 1 / 200.0, 0.0073, 10.0
    t = np.arange(0, 4.0, dt)
    ramp = np.clip(t / 0.5, 0, 1)  # smooth start: the signal is at rest before t = 0
    y = ramp * np.sin(2 * np.pi * f * t)
    d = delay_signal(y, tau, dt)
    exact = np.clip((t - tau) / 0.5, 0, 1) * np.sin(2 * np.pi * f * (t - tau))
    mid = (t > 1.0) & (t < 3.0)
    assert np.max(np.abs(d[mid] - exact[mid])) < 0.01
    # an integer delay is a plain shift
    assert np.allclose(delay_signal(y, 2 * dt, dt)[2:], y[:-2], atol=1e-9)
    with pytest.raises(ValidationError, match="delay_s >= 0"):
        delay_signal(y, -0.001, dt)


def test_white_noise_floor_of_a_known_signal_plus_noise():
    # reference: the generator's own sigma; a 1.3 Hz body motion and a 11 Hz wheel hop
    # (far below the 50 Hz band) do not leak into the estimate
    rng = np.random.default_rng(0)
    dt = 1 / 200.0
    t = np.arange(0, 8.0, dt)
    y = 2.0 * np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 11.0 * t)
    for sigma in (0.01, 0.05):
        sd, variance = white_noise_sd(y + rng.normal(0, sigma, t.size), dt)
        # 400 lines from 50 Hz to Nyquist; the Hann taper's variance factor N sum(w^4) /
        # sum(w^2)^2 tends to 35/18 (its integrals of sin^4 and sin^8)
        assert variance == pytest.approx(35 / 18 / 400, rel=0.01)
        assert sd == pytest.approx(sigma, rel=0.08)


@pytest.mark.parametrize("kind", OUT_OF_LIBRARY_KINDS)
def test_out_of_library_generator_hides_physics_outside_the_candidates(kind):
    case = make_ride_case(5, kind, speeds_kmh=(50.0,), random_road=False)
    truth = case.truth
    assert not truth.in_library and truth.effects == [] and truth.mismatch["kind"] == kind
    blob = json.dumps([r.meta for r in case.fit + case.heldout])
    assert kind not in blob
    # the mismatch is in the measurement: the reference-vehicle model with the truth's
    # own design values misses it by more than the sensor noise on some channel
    m = MinibusRideAdapter()
    rec = case.fit[0]
    pred = m.simulate(m.theta_from(truth.base), rec)
    worst = max(np.std(rec.outputs[c] - pred[c]) / np.sqrt(np.mean(pred[c] ** 2)) for c in pred)
    assert worst > 2 * truth.noise_fraction


def test_seat_sensor_gain_and_lag_are_what_the_truth_says():
    # independent check of the sensor mismatch: regression of the measured seat channel
    # on the noise-free reference prediction gives the gain; the cross-correlation peak
    # (parabolic interpolation) gives the lag
    g = make_ride_case(5, "seat_sensor_gain", speeds_kmh=(50.0,), random_road=False)
    m = MinibusRideAdapter()
    rec = g.fit[0]
    clean = m.simulate(m.theta_from(g.truth.base), rec)["acc_seat"]
    gain = float(rec.outputs["acc_seat"] @ clean / (clean @ clean))
    assert gain == pytest.approx(g.truth.mismatch["gain"], rel=0.01)
    lag_case = make_ride_case(6, "seat_sensor_lag")
    rec = lag_case.heldout[-1]  # the random-road run: broadband
    clean = m.simulate(m.theta_from(lag_case.truth.base), rec)["acc_seat"]
    xc = np.correlate(rec.outputs["acc_seat"], clean, "full")[clean.size - 1 : clean.size + 4]
    k = int(np.argmax(xc))
    k_frac = k + 0.5 * (xc[k - 1] - xc[k + 1]) / (xc[k - 1] - 2 * xc[k] + xc[k + 1])
    delay = k_frac * rec.sample_interval
    assert delay == pytest.approx(lag_case.truth.mismatch["delay_s"], abs=1.5e-3)


def test_tyre_stiffness_moves_the_wheel_hop_resonance():
    # closed form: the wheel-hop frequency of an unsprung mass between the tyre and the
    # (much softer) suspension scales as sqrt(k_tyre + k_susp); the truth vehicle's
    # road-to-front-wheel transfer function (linearised ride model, cross-spectrum on
    # the random road) peaks at a frequency moved by about that ratio
    from scipy import signal as sig

    from benchmarks.ride_mismatch import mismatch_vehicle
    from suspenv.diagnosis.ride.model import half_step_inputs
    from suspenv.models.minibus import REFERENCE_MINIBUS, vehicle_parameters
    from suspenv.models.minibus.ride_model import RideModel

    case = make_ride_case(9, "tyre_stiffness")
    factor = case.truth.mismatch["factor"]
    zh, zd, dt = half_step_inputs(case.heldout[-1])
    road = zh[0::2][:-1, 0]
    peaks = []
    for vehicle in (REFERENCE_MINIBUS, mismatch_vehicle(case.truth.mismatch)):
        params = vehicle_parameters(STUDY_PICK[None, :], "no_load", vehicle)
        out = RideModel(params, linear=True).simulate(zh, zd, dt, record_states=True)
        f, pxy = sig.csd(road, out.states[0, 3], 1 / dt, nperseg=512)
        _, pxx = sig.welch(road, 1 / dt, nperseg=512)
        band = (f > 5) & (f < 25)
        peaks.append(f[band][np.argmax(np.abs(pxy / pxx)[band])])
    kt = REFERENCE_MINIBUS.tyre_vertical_stiffness
    ks = 8.8e4 * 1e-3 * (180 / np.pi) / 0.33**2  # front wheel rate from T1 (N*mm/deg)
    expected = np.sqrt((factor * kt + ks) / (kt + ks))
    assert abs(expected - 1) > 0.1  # the case moves the resonance noticeably
    assert peaks[1] / peaks[0] == pytest.approx(expected, rel=0.06)


@pytest.fixture(scope="module")
def gain_case_baseline():
    from suspenv.diagnosis.fitting import fit

    case = make_ride_case(4, "seat_sensor_gain", speeds_kmh=(50.0,), random_road=False)
    return case, fit(MinibusRideAdapter(), case.fit, max_nfev=10)


def test_noise_floor_matches_the_generators_noise(gain_case_baseline):
    # reference: the generator's noise (measured minus the noise-free truth signal)
    case, fit = gain_case_baseline
    floor, _ = noise_floor(fit, case.heldout)
    rec = case.heldout[0]
    m = MinibusRideAdapter()
    clean = m.simulate(m.theta_from(case.truth.base), rec)
    for c in ("acc_front", "acc_rear"):  # the seat channel also carries the gain error
        assert floor[c] == pytest.approx(np.std(rec.outputs[c] - clean[c]), rel=0.15)


def test_residual_check_flags_a_gain_error_but_not_pure_noise(gain_case_baseline):
    case, fit = gain_case_baseline
    chk = residual_check(fit, fit, case.heldout, [])
    # a seat gain error of 8-15 % is far above 2-4 % noise and structured
    assert chk.residual_remains and chk.excess_ratio > 1.5 and chk.ljung_box_p < 0.01
    assert chk.view().remains and "sensor-noise floor" in chk.sentence() and not chk.confident
    # control: a no-effect case fitted by the right model leaves white noise only
    ctrl = make_ride_case(4, None, speeds_kmh=(50.0,), random_road=False)
    from suspenv.diagnosis.fitting import fit

    f0 = fit(MinibusRideAdapter(), ctrl.fit, max_nfev=10)
    c0 = residual_check(f0, f0, ctrl.heldout, [])
    assert not c0.residual_remains and c0.excess_ratio < 1.1, c0


def test_bounds_check_detects_a_stretched_ride_element(gain_case_baseline):
    # planted: a seat-mount element with its stiffness at the fit bound; the shared
    # check (checks.bounds) reads the named element's parameters
    import dataclasses

    from suspenv.diagnosis.checks.bounds import parameters_at_bounds

    _, fit = gain_case_baseline
    model = MinibusRideAdapter([ride_effect("kelvin_voigt", "seat_mount")])
    lo, hi = model.bounds()
    theta = np.concatenate([fit.theta, [hi[-2], 0.5 * (lo[-1] + hi[-1])]])
    names = model.parameter_names
    on = dataclasses.replace(fit, model=model, theta=theta, names=tuple(names))
    named = [SimpleNamespace(params={n: 0.0 for n in names if n.startswith("kelvin_voigt@")})]
    at = parameters_at_bounds(on, named)  # type: ignore[arg-type]
    assert len(at) == 1 and at[0].startswith("kelvin_voigt@seat_mount.k = "), at
    assert at[0].endswith("at its upper bound"), at
    assert parameters_at_bounds(fit, named) == []  # type: ignore[arg-type]


@pytest.mark.slow
@pytest.mark.parametrize("kind", OUT_OF_LIBRARY_KINDS)
def test_out_of_library_case_is_not_named_with_confidence(kind):
    # full protocol (seed 23, not a reported seed): either nothing named or a named
    # element flagged as leaving a residual (or stretched to a bound)
    case = make_ride_case(23, kind)
    d = diagnose(case.fit, RideFamily(screen_count=3), holdout=case.heldout)
    assert not d.confident, d.verdict
    assert d.residual.residual_remains or not d.named, d.verdict
