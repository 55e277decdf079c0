"""Motion inputs of a component recording: noise band, derivative, velocity channel check.

References: closed forms (the derivative of a sine, a delayed or scaled sine), white
noise's variance share above a cut-off, and the engine on development cases whose
velocity channel is what a rig's software makes of a noisy displacement (a
Savitzky-Golay derivative).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import savgol_filter

from benchmarks.component_truth import make_case
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.component.motion_inputs import (
    VELOCITY_MISMATCH,
    compare_velocity,
    conditioned,
    derivative,
    lowpass,
    motion_cutoff,
)
from suspenv.diagnosis.component.rig import describe_rig
from suspenv.diagnosis.engine import diagnose, make_family
from suspenv.measurements import Recording

FS = 500.0
UNITS = {"displacement": "m", "velocity": "m/s", "force": "N"}


def _sine(f0: float = 3.0, seconds: float = 6.0, amp: float = 0.01):
    t = np.arange(int(seconds * FS)) / FS
    w = 2 * np.pi * f0
    return t, amp * np.sin(w * t), amp * w * np.cos(w * t)


def test_five_point_derivative_of_a_sine_is_within_its_truncation_bound():
    # closed form: d/dt sin(wt) = w cos(wt); the five-point stencil's gain error is
    # (w dt)^4 / 30 to leading order
    t, x, v = _sine(f0=8.0)
    d = derivative(x, FS)
    wdt = 2 * np.pi * 8.0 / FS
    err = np.max(np.abs(d[2:-2] - v[2:-2])) / np.max(np.abs(v))
    assert err <= 1.2 * wdt**4 / 30
    assert err > 0.5 * wdt**4 / 30  # the bound is the stencil's own error, not slack


def test_noise_band_passes_the_motion_and_drops_white_noise():
    t, x, _ = _sine(f0=3.0)
    rng = np.random.default_rng(0)
    noisy = x + 2e-5 * rng.standard_normal(x.size)
    fc = motion_cutoff(noisy, FS)
    assert fc is not None
    # above the motion (3 Hz), far below Nyquist (250 Hz): most noise power is removed
    assert 3.0 < fc < 0.2 * FS / 2


def _broadband(seed: int, fs: float = 100.0, seconds: float = 10.0):
    """Sines of random phase every 0.1 Hz from 0.1 Hz to 0.4 of the Nyquist frequency,
    amplitude falling as f^-1.5 (a motion with content up to the noise band): t, x, dx/dt."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * fs)) / fs
    f = np.arange(0.1, 0.2 * fs + 1e-9, 0.1)
    a, ph = 0.01 * (f / f[0]) ** -1.5, rng.uniform(0, 2 * np.pi, f.size)
    arg = 2 * np.pi * f[:, None] * t + ph[:, None]
    return t, (a[:, None] * np.sin(arg)).sum(0), ((2 * np.pi * f * a)[:, None] * np.cos(arg)).sum(0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_broadband_motion_is_cut_where_its_derivative_is_least_wrong(seed):
    # reference: the exact derivative of the sines, against the derivative of the noisy
    # displacement low-passed at every cut-off of the grid (the error measured, not
    # estimated); no cut-off removes noise alone, yet one leaves far less error than none
    from suspenv.diagnosis.component.motion_inputs import (
        CUTOFF_GRID,
        least_error_cutoff,
        noise_variance,
    )

    fs = 100.0
    t, x, v = _broadband(seed, fs)
    noisy = x + 3e-3 * float(np.std(x)) * np.random.default_rng(seed + 9).standard_normal(x.size)
    assert motion_cutoff(noisy, fs) is None

    inner = slice(100, -100)  # the filter's and the stencil's ends left out

    def error(fc: float | None) -> float:
        y = noisy if fc is None else lowpass(noisy, fs, fc)
        return float(np.sqrt(np.mean((derivative(y, fs) - v)[inner] ** 2)))

    measured = {fc: error(fc) for fc in (frac * 0.5 * fs for frac in CUTOFF_GRID)}
    chosen = least_error_cutoff(noisy, fs, noise_variance(noisy, fs))
    assert chosen is not None
    assert error(chosen) < 0.7 * error(None)  # 0.50-0.55 of it on these draws
    # the best of the grid, measured, within the periodogram's spread
    assert error(chosen) <= 1.1 * min(measured.values())


def test_a_broadband_recording_says_its_cut_off_removes_some_motion():
    fs = 100.0
    t, x, v = _broadband(3, fs)
    noisy = x + 3e-3 * float(np.std(x)) * np.random.default_rng(4).standard_normal(x.size)
    rec = Recording("wide", "dyno", t, {"displacement": noisy}, {"force": 0 * t}, UNITS)
    (_,), (check,) = conditioned([rec], ("displacement", "velocity"))
    assert check.broadband and check.cutoff_hz is not None
    assert "broadband" in check.words()[0]
    # the same motion without noise is left as it was
    clean = Recording("wide", "dyno", t, {"displacement": x}, {"force": 0 * t}, UNITS)
    (_,), (check,) = conditioned([clean], ("displacement", "velocity"))
    assert check.cutoff_hz is None and not check.broadband


def test_lowpass_passes_a_slow_sine_at_any_phase_up_to_the_record_ends():
    # closed form: a zero-phase Butterworth of order 4 each way passes a sine of
    # frequency f at gain 1 / (1 + (f / fc)^8); a sine cut at an arbitrary phase is curved
    # at the record's ends, where the plain odd extension through the end sample starts a
    # transient of the filter's length (26-97 % of the amplitude at these phases)
    from scipy.signal import sosfiltfilt

    from suspenv.models.components.base import butterworth

    fc, f0 = 2.0, 0.9
    t = np.arange(0.0, 12.0, 1.0 / FS)
    gain = 1.0 / (1.0 + (f0 / fc) ** 8)
    for phase in (0.0, 1.0, 2.0):
        y = np.sin(2 * np.pi * f0 * t + phase)
        assert np.max(np.abs(lowpass(y, FS, fc) - gain * y)) < 0.04
        plain = sosfiltfilt(butterworth(fc, FS).copy(), y)
        assert np.max(np.abs(plain - gain * y)) > 0.2  # what the extension removes


def test_lowpass_does_not_lift_the_noise_at_the_record_ends():
    # white noise low-passed: in the first eighth of a second the output's spread stays
    # near the mid-record one (the end's value is a quadratic through a quarter second of
    # samples, not the last sample's noise, on which the plain odd extension pivots: 7.4 x)
    fc = 2.0
    e = np.random.default_rng(0).standard_normal((200, int(12.0 * FS)))
    low = lowpass(e, FS, fc)
    mid = np.std(low[:, 2000:4000])
    assert np.std(low[:, :62]) < 2.0 * mid
    assert np.std(low[:, -62:]) < 2.0 * mid
    # linear, like the filter: the outputs low-passed with the motion rely on it
    y = np.sin(np.arange(e.shape[1]) / 300.0)
    assert np.allclose(lowpass(3.0 * y + e[0], FS, fc), 3.0 * lowpass(y, FS, fc) + low[0])


def test_clean_motion_gets_no_cut_off_and_an_unchanged_recording():
    t, x, v = _sine()
    rec = Recording("clean", "dyno", t, {"displacement": x, "velocity": v}, {"force": 0 * t}, UNITS)
    (out,), (check,) = conditioned([rec], ("displacement", "velocity"))
    assert check.cutoff_hz is None and check.worst_mismatch < 1e-6
    assert out is rec


@pytest.mark.parametrize("lag_samples", [1.0, -2.0])
def test_a_delayed_velocity_channel_gives_its_lag_with_sign(lag_samples):
    # closed form: v(t - tau) = cos(w tau) v(t) - sin(w tau) / w dv/dt, so the channel
    # lags by sin(w tau) / w (~ tau); for one sine the gain and curvature terms are
    # one direction (d2v/dt2 = -w^2 v), so only their sum is defined
    t, x, _ = _sine()
    tau = lag_samples / FS
    w = 2 * np.pi * 3.0
    late = 0.01 * w * np.cos(w * (t - tau))
    gain, lag, mismatch = compare_velocity(late, derivative(x, FS), FS)
    assert lag == pytest.approx(np.sin(w * tau) / w, rel=1e-3)
    assert np.sign(lag) == np.sign(lag_samples)
    assert mismatch > VELOCITY_MISMATCH


def test_a_scaled_velocity_channel_gives_its_gain_error():
    # two tones, so that the gain (v) and the curvature (d2v/dt2) are told apart
    t, x1, v1 = _sine(f0=3.0)
    _, x2, v2 = _sine(f0=7.0, amp=0.004)
    gain, lag, _ = compare_velocity(0.98 * (v1 + v2), derivative(x1 + x2, FS), FS)
    assert gain == pytest.approx(-0.02, abs=1e-4)
    assert abs(lag) < 1e-6


def _derived(rec: Recording, noise: float = 0.002, window: int = 21) -> Recording:
    """The rig's software: displacement with white noise (``noise`` x its amplitude),
    velocity from a Savitzky-Golay derivative of it (``window`` samples, order 2)."""
    x = rec.inputs["displacement"]
    rng = np.random.default_rng(1)
    dt = float(np.median(np.diff(rec.time)))
    amp = float(np.percentile(np.abs(x - np.median(x)), 98))
    xm = x + noise * amp * rng.standard_normal(x.size)
    v = savgol_filter(xm, window, 2, deriv=1, delta=dt)
    inputs = {**rec.inputs, "displacement": xm, "velocity": v}
    return Recording(rec.name, rec.test, rec.time, inputs, rec.outputs, rec.units, rec.meta)


def test_a_filtered_derivative_channel_is_found_and_said():
    rec = _derived(make_case("damper", 0, 0).recording)
    channels = ("displacement", "velocity")
    (band,), (check,) = conditioned([rec], channels)
    assert check.mismatch > VELOCITY_MISMATCH and check.cutoff_hz is not None
    words = " ".join(check.words())
    assert "not the derivative of the displacement" in words and "low-passed" in words
    # "band": the channel low-passed; "displacement": the displacement's derivative
    (derived,), _ = conditioned([rec], channels, "displacement")
    np.testing.assert_array_equal(derived.inputs["displacement"], band.inputs["displacement"])
    assert not np.allclose(derived.inputs["velocity"], band.inputs["velocity"])
    # "channel": the recording exactly as it was
    kept, checks = conditioned([rec], channels, "channel")
    assert kept[0] is rec and checks == []


def test_velocity_source_is_validated_with_rule_and_value():
    with pytest.raises(ValidationError, match=r"version in .* but got 'smooth'"):
        conditioned([], ("displacement", "velocity"), "smooth")
    with pytest.raises(ValidationError, match=r"velocity_source in .* but got 'smooth'"):
        describe_rig("damper", [_meta_rig({"velocity_source": "smooth"})])
    rig = describe_rig("damper", [_meta_rig({"velocity_source": "channel"})])
    assert rig.velocity_source == "channel"


def _meta_rig(entries: dict) -> Recording:
    t, x, v = _sine(seconds=1.0)
    return Recording(
        "m",
        "dyno",
        t,
        {"displacement": x, "velocity": v},
        {"force": 0 * t},
        UNITS,
        {"rig": entries},
    )


@pytest.mark.parametrize("seed", [0, 9])
def test_no_false_alarm_when_the_velocity_is_a_smoothed_derivative(seed):
    # development controls (no effect): without the check, the smoothing of the channel
    # (a gain falling with frequency) was named a viscoelastic lag
    rec = _derived(make_case("damper", seed, 0).recording)
    diag = diagnose(rec, make_family("damper"))
    assert diag.named == [] and not diag.unexplained, diag.headline


def test_effect_is_named_when_the_velocity_is_a_smoothed_derivative():
    case = make_case("damper", 6, 1)
    assert [e["kind"] for e in case.truth.effects] == ["coulomb_friction"]
    diag = diagnose(_derived(case.recording), make_family("damper"))
    assert diag.named and diag.named_kinds[0] == "coulomb_friction", diag.headline


def test_own_generator_records_the_motion_as_rigs_do_in_half_of_the_cases():
    recorded = []
    for seed in range(10):
        case = make_case("damper", seed, 0)
        if case.truth.motion is None:
            continue
        recorded.append(seed)
        rec = case.recording
        x, v = rec.inputs["displacement"], rec.inputs["velocity"]
        assert 5e-4 <= case.truth.motion["noise_share"] <= 2e-3
        # the recorded velocity is the Savitzky-Golay derivative of the noisy displacement
        w = case.truth.motion["savgol_window"]
        dt = float(np.median(np.diff(rec.time)))
        np.testing.assert_allclose(v, savgol_filter(x, w, 2, deriv=1, delta=dt))
        (_,), (check,) = conditioned([rec], ("displacement", "velocity"))
        assert check.cutoff_hz is not None, seed
    assert 3 <= len(recorded) <= 7


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("cutoff", [None, 20.0])
def test_derivative_noise_matches_differentiated_white_noise(order, cutoff):
    # reference: white noise passed through the same low-pass and stencil, by sampling
    from suspenv.diagnosis.component.motion_inputs import derivative_noise, lowpass

    rng = np.random.default_rng(5)
    e = 1e-4 * rng.standard_normal(200_000)
    y = e if cutoff is None else lowpass(e, FS, cutoff)
    for _ in range(order):
        y = derivative(y, FS)
    sampled = float(np.std(y[1000:-1000]))
    assert derivative_noise(1e-8, FS, cutoff, order) == pytest.approx(sampled, rel=0.02)


def test_preferred_version_keeps_consistent_rates_and_replaces_filtered_ones():
    from suspenv.diagnosis.component.motion_inputs import MotionCheck, preferred_version

    def check(mismatch: float, noise: float) -> MotionCheck:
        return MotionCheck("r", None, 0.0, 0.0, mismatch, mismatch, noise)

    assert preferred_version([check(1e-4, 0.05)]) == "band"  # noise alone does not decide
    assert preferred_version([check(0.01, 0.002)]) == "displacement"
    assert preferred_version([check(0.01, 0.03)]) is None  # both flawed: the fit decides
    assert preferred_version([]) == "band"


# ------------------------------------------------- outputs compared low-passed (the guide)
def _moves(fs: float = 500.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Time [s], position [m], velocity [m/s], acceleration [m/s^2] of three cubic-spline
    moves of 0.1 m with rests between them: the acceleration jumps where a move starts or
    ends, so its content runs far above any motion cut-off."""
    t = np.arange(0.0, 6.0, 1.0 / fs)
    x = np.zeros_like(t)
    for start, sign in ((0.5, 1.0), (2.5, -1.0), (4.5, 1.0)):
        s = np.clip((t - start) / 1.0, 0.0, 1.0)
        x += sign * 0.1 * (3 * s**2 - 2 * s**3)
    v = np.gradient(x, t)
    a = np.gradient(v, t)
    return t, x, v, a


def test_the_guide_prediction_is_low_passed_beyond_its_inertia_and_damping():
    from scipy.signal import butter, sosfiltfilt

    from suspenv.models.components import FrictionGuideModel
    from suspenv.models.components.base import OUTPUT_LOWPASS_KEY
    from suspenv.models.effects import make_effect

    t, x, v, a = _moves()
    units = {"time": "s", "position": "m", "velocity": "m/s", "acceleration": "m/s^2"}
    rec = Recording(
        "moves", "guide", t, {"position": x, "velocity": v, "acceleration": a}, {}, units, {}
    )
    model = FrictionGuideModel([make_effect("coulomb_friction").with_params({"f_c": 5.0})])
    theta = model.theta_from({"m": 20.0, "c": 50.0})
    raw = model.simulate(theta, rec)["force"]
    tagged = Recording("moves", "guide", t, dict(rec.inputs), {}, units, {OUTPUT_LOWPASS_KEY: 15.0})
    low = model.simulate(theta, tagged)["force"]
    # reference: the zero-phase low-pass (its gain checked against the closed form above)
    # of the friction force only, and scipy's Butterworth (order 4 each way) mid-record
    linear = 20.0 * a + 50.0 * v
    assert np.allclose(low, linear + lowpass(raw - linear, 500.0, 15.0), atol=1e-9)
    assert not np.allclose(low, raw, atol=0.1)  # the friction step is smoothed ...
    assert np.allclose(low - linear, lowpass(raw - linear, 500.0, 15.0), atol=1e-9)  # ... alone
    sos = butter(4, 15.0, fs=500.0, output="sos")
    mid = slice(200, -200)  # ten periods of the cut-off from the ends
    assert np.allclose((low - linear)[mid], sosfiltfilt(sos, raw - linear)[mid], atol=1e-6)


def test_outputs_low_passed_with_the_motion_cancel_a_linear_force_exactly():
    from suspenv.diagnosis.component.motion_inputs import low_passed_outputs
    from suspenv.models.components import FrictionGuideModel
    from suspenv.models.components.base import OUTPUT_LOWPASS_KEY

    t, x, v, a = _moves()
    fs, fc = 500.0, 12.0
    force = 20.0 * a + 50.0 * v  # a guide without friction: inertia and damping only
    noise = 0.05 * np.random.default_rng(4).standard_normal(t.size)
    units = {"time": "s", "position": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}
    # the motion as the conditioning gives it: low-passed at fc
    inputs = {
        "position": lowpass(x, fs, fc),
        "velocity": lowpass(v, fs, fc),
        "acceleration": lowpass(a, fs, fc),
    }
    rec = Recording("moves", "guide", t, inputs, {"force": force + noise}, units, {})
    model = FrictionGuideModel()
    theta = model.theta_from({"m": 20.0, "c": 50.0})
    # the recorded force against the low-passed motion misses the inertia's content
    # above fc where the moves start and end ...
    miss = rec.outputs["force"] - model.simulate(theta, rec)["force"]
    assert np.max(np.abs(miss)) > 20 * 0.05
    # ... which comparing the force low-passed alike removes, leaving the noise in band
    low = low_passed_outputs(rec, fc)
    assert low.meta[OUTPUT_LOWPASS_KEY] == fc
    left = low.outputs["force"] - model.simulate(theta, low)["force"]
    assert np.allclose(left, lowpass(noise, fs, fc), atol=1e-9)


def test_the_residual_check_reads_outputs_compared_low_passed_as_recorded():
    from suspenv.diagnosis.component.motion_inputs import as_recorded, low_passed_outputs
    from suspenv.diagnosis.component.residual_left import residual_left
    from suspenv.diagnosis.fitting import fit
    from suspenv.diagnosis.split import Split
    from suspenv.models.components import FrictionGuideModel
    from suspenv.models.components.base import OUTPUT_LOWPASS_KEY

    fs, fc = 500.0, 10.0
    t = np.arange(0.0, 40.0, 1.0 / fs)
    w = 2 * np.pi * 0.5
    x = 0.05 * np.sin(w * t)
    v, a = 0.05 * w * np.cos(w * t), -0.05 * w * w * np.sin(w * t)
    rng = np.random.default_rng(8)
    # a guide of 20 kg and 50 N s/m, a position ripple (below 6 Hz) and white noise of 2 N
    force = 20.0 * a + 50.0 * v + 0.8 * np.sin(2 * np.pi * x / 0.03) + rng.normal(0, 2.0, t.size)
    units = {"time": "s", "position": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}
    inputs = {"position": x, "velocity": v, "acceleration": a}
    raw = Recording("sweep", "guide", t, inputs, {"force": force}, units, {})
    low = low_passed_outputs(raw, fc)
    # as_recorded undoes low_passed_outputs: the channels as recorded, no cut-off in meta
    back = as_recorded(low, raw.outputs)
    assert OUTPUT_LOWPASS_KEY in low.meta and OUTPUT_LOWPASS_KEY not in back.meta
    assert np.array_equal(back.outputs["force"], force)
    model = FrictionGuideModel()
    res = fit(model, [low])
    split = Split([low], None, [], None, "all samples")
    read = residual_left(res, split, recorded={"sweep": raw.outputs})[0]
    # reference: the same model and parameters on a split of the raw recording itself
    same = residual_left(res, Split([raw], None, [], None, "all samples"))[0]
    assert read.noise_rms == pytest.approx(same.noise_rms, rel=1e-12)
    assert read.structured_rms == pytest.approx(same.structured_rms, rel=1e-12)
    # the ripple (0.57 N RMS) is small against the 2 N of noise as recorded, large against
    # what is left of the noise below 10 Hz: read low-passed it would count
    assert read.ratio < 0.6 and not read.state_remains
    filtered = residual_left(res, split)[0]
    assert filtered.ratio > 0.6


def test_harmonics_kept_counts_the_motion_cycles_under_a_cut_off():
    from suspenv.diagnosis.component.motion_inputs import harmonics_kept

    t = np.arange(0.0, 40.0, 0.002)
    units = {"time": "s", "position": "m", "velocity": "m/s", "force": "N"}
    x = 0.05 * np.sin(2 * np.pi * 0.5 * t + 0.3)  # 0.5 Hz: 20 cycles
    rec = Recording("sine", "guide", t, {"position": x}, {"force": x}, units, {})
    # the cycles counted between upward crossings (19 whole ones in 40 s): about fc / 0.5 Hz
    assert harmonics_kept(rec, 10.0) == pytest.approx(20.0, rel=0.06)
    assert harmonics_kept(rec, 2.0) == pytest.approx(4.0, rel=0.06)
    still = Recording("still", "guide", t, {"position": 0 * t + 0.01}, {"force": x}, units, {})
    assert harmonics_kept(still, 10.0) == float("inf")  # no cycle: nothing to resolve
