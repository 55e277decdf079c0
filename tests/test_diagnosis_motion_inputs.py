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

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.component.motion_inputs import (
    VELOCITY_MISMATCH,
    compare_velocity,
    conditioned,
    derivative,
    motion_cutoff,
)
from suspenv.diagnosis.component.rig import describe_rig
from suspenv.diagnosis.component.truth import make_case
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
