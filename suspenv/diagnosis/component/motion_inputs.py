"""The motion inputs as the component felt them: noise removed, velocity consistent.

A dyno or guide recording gives the component's displacement ``x`` [m] and, usually, a
velocity channel ``v`` [m/s] (and a guide its acceleration [m/s^2]). A model fitted to
them treats them as exact. Two things a rig does to them make that wrong:

* **noise on the motion channels.** Force = ``c v_true``, fitted against
  ``v_measured = v_true + e``, leaves ``-c e`` in the residual, correlated with the
  input: any element that smooths the predicted force (a Maxwell lag, a sensor lag)
  then "explains" it (errors in variables). The motion is imposed by the actuator and
  lies in a narrow band; white noise spreads to the Nyquist frequency. The channels are
  low-passed (zero phase, Butterworth, order 4 each way) at the lowest cut-off whose
  removed part is still white noise (:func:`motion_cutoff`): the smallest ``f_c``
  at which ``var(x - lowpass(x, f_c))`` is at most :data:`NOISE_TOLERANCE` times what
  white noise of the level seen above ``0.8 f_Nyquist`` would give. A broadband motion,
  of which every cut-off removes some, is low-passed where its derivative is left the
  least error, the noise passed plus the motion removed (:func:`least_error_cutoff`):
  unfiltered, a dyno's velocity from a noisy displacement carries a force error of
  several times the load cell's noise, and a lag of a few milliseconds is named for
  smoothing it. A clean recording (noise below :data:`NEGLIGIBLE_NOISE` of the motion)
  keeps every sample.
* **a velocity channel that is a filtered derivative of the displacement** (a
  Savitzky-Golay or a causal differentiator in the rig's software): it lags or is
  attenuated at the higher test frequencies, and a frequency-dependent force error looks
  like viscoelastic damping. The channel is compared with the derivative of the
  displacement over the motion band (:func:`compare_velocity`); a lag and curvature part
  above :data:`VELOCITY_MISMATCH` of the velocity's RMS means the channel is not the
  displacement's derivative, and the report says so.

Which rates the fit uses is ``velocity_source`` in the rig description
(:mod:`suspenv.diagnosis.component.rig`): ``"auto"`` (default) fits the version of
:func:`conditioned` that :func:`preferred_version` names, or where it names none both,
the smaller baseline residual deciding, as the report says; ``"displacement"`` always
the derivatives, ``"channel"`` the channels exactly as recorded (no low-pass, no check).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import sosfreqz

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.component.motion import cycle_index, motion
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.models.components.base import OUTPUT_LOWPASS_KEY, butterworth, lowpass

VELOCITY_SOURCES = ("auto", "displacement", "channel")
#: versions of the motion a fit can be given (:func:`conditioned`)
MOTION_VERSIONS = ("channel", "band", "displacement")
#: a removed part up to this multiple of the white-noise expectation is noise
NOISE_TOLERANCE = 1.25
#: candidate cut-offs, as fractions of the Nyquist frequency (descending, 17 % apart)
CUTOFF_GRID = tuple(float(f) for f in np.geomspace(0.4, 0.004, 31))
#: samples whose velocity difference is beyond this many robust standard deviations are
#: local events (a step in a test signal's velocity), not a filter, and left out
SPIKE_LIMIT = 8.0
#: the white-noise level is read from what lies above this fraction of Nyquist
NOISE_BAND = 0.8
#: a velocity channel differing from the displacement's derivative by more than this
#: share of its RMS in a frequency-dependent way (lag, gain curvature over the band) is
#: not its derivative: a 0.1 % lag-like force error is already named as a viscoelastic
#: element on a low-noise dyno recording
VELOCITY_MISMATCH = 0.001
#: white noise below this share of the motion's standard deviation is none: float
#: rounding, the filter's start-up ringing (a 16-bit transducer's quantisation noise,
#: about 1.2e-5 of a full-range sine's standard deviation, is harmless to a fit)
NEGLIGIBLE_NOISE = 1e-5
#: the displacement's derivatives are clean when the noise they carry is at most this
#: share of their RMS (at most the force noise of a dyno)
DERIVATIVE_CLEAN = 0.01
#: fewest samples for the noise estimate and the comparison
MIN_SAMPLES = 256


@dataclass(frozen=True)
class MotionCheck:
    """What was found and done in one recording's motion channels.

    Attributes:
        recording: recording name.
        cutoff_hz: low-pass cut-off [Hz] of the motion channels (None: no noise found).
        broadband: the cut-off removes some of the motion too (:func:`least_error_cutoff`).
        gain_error: ``g - 1`` of the velocity channel against the derivative (None: no
            velocity channel).
        lag_s: delay of the velocity channel behind the derivative [s] (positive: lags).
        mismatch: the velocity channel's frequency-dependent difference from the
            derivative, as a share of its RMS (None: no velocity channel).
        worst_mismatch: the largest such share over the velocity and acceleration
            channels (0 when neither is recorded).
        derivative_noise: the largest RMS noise the displacement's white noise leaves on
            its derivatives (:func:`derivative_noise`), as a share of their RMS.
        displacement_noise: the standard deviation of the displacement's white noise as
            recorded, sample by sample (:func:`noise_variance`) [displacement unit].
    """

    recording: str
    cutoff_hz: float | None
    gain_error: float | None
    lag_s: float | None
    mismatch: float | None
    worst_mismatch: float
    derivative_noise: float = 0.0
    displacement_noise: float = 0.0
    broadband: bool = False

    def words(self) -> list[str]:
        """Sentences for the report's evidence."""
        out = []
        if self.cutoff_hz is not None:
            why = (
                "a broadband motion: the cut-off of least error in its derivatives, the "
                "noise passed against the motion removed"
                if self.broadband
                else "what lies above it is white noise"
            )
            out.append(
                f"recording {self.recording}: motion channels low-passed at "
                f"{self.cutoff_hz:.3g} Hz (zero phase; {why})"
            )
        if self.mismatch is not None and self.mismatch > VELOCITY_MISMATCH:
            lag = "" if self.lag_s is None else f", lag {1e3 * self.lag_s:+.3g} ms"
            gain = "" if self.gain_error is None else f"gain {100 * self.gain_error:+.2g} %"
            out.append(
                f"recording {self.recording}: the velocity channel is not the derivative of "
                f"the displacement ({gain}{lag}; {100 * self.mismatch:.2g} % of its RMS, a "
                "filtered derivative)"
            )
        return out


def sampling_rate(t: np.ndarray) -> float | None:
    """The sampling rate [Hz] of a uniformly sampled time axis, else None."""
    dt = np.diff(t)
    if dt.size < MIN_SAMPLES or not np.all(dt > 0):
        return None
    step = float(np.median(dt))
    return None if float(np.max(np.abs(dt - step))) > 0.01 * step else 1.0 / step


#: fewest harmonics of a recording's motion cycle that a cut-off must keep for its outputs
#: to be compared low-passed (:func:`harmonics_kept`): with fewer, a friction step or an
#: impact is smoothed over more than a twentieth of a cycle and its shape is lost, while
#: what stays of the residual is slow noise
OUTPUT_LOWPASS_HARMONICS = 10


def harmonics_kept(rec: RecordingLike, fc: float) -> float:
    """Harmonics of ``rec``'s motion cycle below the cut-off ``fc`` [Hz]: ``fc`` over
    the cycle rate (motion cycles, :func:`~suspenv.diagnosis.component.motion.cycle_index`,
    per second); inf for a recording without a whole cycle."""
    t = np.asarray(rec.time, float)
    cycles = int(cycle_index(motion(rec)[0]).max())
    if cycles < 1 or not t[-1] > t[0]:
        return float("inf")
    return float(fc) * float(t[-1] - t[0]) / cycles


def low_passed_outputs(rec: RecordingLike, fc: float) -> RecordingLike:
    """``rec`` with its output channels low-passed at ``fc`` [Hz] by :func:`lowpass`, its
    meta naming the cut-off (``OUTPUT_LOWPASS_KEY``: the prediction is then low-passed
    alike); unchanged without a regular time base. :func:`as_recorded` undoes it."""
    if (fs := sampling_rate(np.asarray(rec.time, float))) is None:
        return rec
    outputs = {k: lowpass(np.asarray(v, float), fs, fc) for k, v in rec.outputs.items()}
    meta = {**dict(rec.meta), OUTPUT_LOWPASS_KEY: float(fc)}
    return replace(rec, outputs=outputs, meta=meta)  # type: ignore[type-var]


def as_recorded(rec: RecordingLike, outputs: Mapping[str, np.ndarray]) -> RecordingLike:
    """``rec`` with the output channels ``outputs`` (as recorded) and no
    ``OUTPUT_LOWPASS_KEY`` in its meta: the prediction is then not low-passed."""
    meta = {k: v for k, v in dict(rec.meta).items() if k != OUTPUT_LOWPASS_KEY}
    return replace(rec, outputs=dict(outputs), meta=meta)  # type: ignore[type-var]


def _removed_share(fs: float, fc: float) -> float:
    """Share of white-noise variance that ``y - lowpass(y, fc)`` keeps."""
    _, h = sosfreqz(butterworth(fc, fs), worN=4096, fs=fs)
    return float(np.mean((1.0 - np.abs(h) ** 2) ** 2))


def _removed(x: np.ndarray, fs: float, fc: float) -> float:
    """Variance of what ``lowpass(x, fs, fc)`` removes, a few periods of the cut-off away
    from the record's ends (the filter's start-up transients; at most 5 % of the samples
    each side, so that no part of the test is left out)."""
    k = min(int(np.ceil(3.0 * fs / fc)), x.size // 20)
    return float(np.var((x - lowpass(x, fs, fc))[k : x.size - k]))


def noise_variance(x: np.ndarray, fs: float) -> float:
    """Variance [unit^2] of the white noise on ``x`` (sampled at ``fs`` [Hz]), read from
    what lies above ``NOISE_BAND`` of the Nyquist frequency (an encoder's quantisation
    counts as noise)."""
    x = np.asarray(x, float)
    top = NOISE_BAND * 0.5 * fs
    return _removed(x, fs, top) / _removed_share(fs, top)


def noisy(x: np.ndarray, s2: float) -> bool:
    """Whether white noise of variance ``s2`` on ``x`` is more than float rounding
    (:data:`NEGLIGIBLE_NOISE` of its standard deviation)."""
    return s2 > (NEGLIGIBLE_NOISE * float(np.std(x))) ** 2


def motion_cutoff(x: np.ndarray, fs: float, s2: float | None = None) -> float | None:
    """The low-pass cut-off [Hz] that removes white noise and nothing of the motion, or
    None when no cut-off removes noise alone (clean data, or a broadband motion:
    :func:`least_error_cutoff`); ``s2``: :func:`noise_variance` of ``x`` when already
    known."""
    x = np.asarray(x, float)
    nyq = 0.5 * fs
    s2 = noise_variance(x, fs) if s2 is None else s2
    if not noisy(x, s2):  # none on x (maybe on its rates)
        return None
    chosen = None
    for frac in CUTOFF_GRID:
        fc = frac * nyq
        if _removed(x, fs, fc) > NOISE_TOLERANCE * s2 * _removed_share(fs, fc):
            break
        chosen = fc
    return None if chosen is None or chosen >= CUTOFF_GRID[0] * nyq else chosen


#: frequency bins the periodogram is averaged over (:func:`least_error_cutoff`): its
#: relative spread per bin falls from 1 to a third
SMOOTH_BINS = 9


def least_error_cutoff(x: np.ndarray, fs: float, s2: float) -> float | None:
    """The cut-off [Hz] of :data:`CUTOFF_GRID` whose low-pass leaves the derivative of the
    displacement ``x`` (sampled at ``fs`` [Hz], white noise of variance ``s2``) the least
    expected error, or None when none leaves less than ``1 / NOISE_TOLERANCE`` of the
    error without a filter (a gain within the noise estimate's tolerance is none). Per bin the
    error is the noise passed, ``|H|^4 s2``, plus the motion removed, ``(1 - |H|^2)^2``
    times its power (the periodogram, Hann window, averaged over :data:`SMOOTH_BINS`,
    less ``s2``), both weighted by the stencil's ``|D|^2`` (:func:`derivative`)."""
    x = np.asarray(x, float)
    window = np.hanning(x.size)
    power = np.abs(np.fft.rfft((x - np.mean(x)) * window)) ** 2 / np.sum(window**2)
    smooth = np.convolve(power, np.full(SMOOTH_BINS, 1.0 / SMOOTH_BINS), mode="same")
    f = np.fft.rfftfreq(x.size, 1.0 / fs)
    weight = _stencil(f, fs) ** 2
    moving = weight * np.maximum(smooth - s2, 0.0)
    errors = {}
    for frac in CUTOFF_GRID:
        gain = np.abs(sosfreqz(butterworth(frac * 0.5 * fs, fs), worN=f, fs=fs)[1]) ** 2
        errors[frac * 0.5 * fs] = float(np.sum((1.0 - gain) ** 2 * moving + gain**2 * weight * s2))
    best = min(errors, key=lambda fc: errors[fc])
    return best if errors[best] * NOISE_TOLERANCE < float(np.sum(weight * s2)) else None


def _stencil(f: np.ndarray, fs: float) -> np.ndarray:
    """Gain [1/s] of :func:`derivative`'s five-point stencil at the frequencies ``f``
    [Hz]: ``(8 sin(w dt) - sin(2 w dt)) / (6 dt)``."""
    w_dt = 2.0 * np.pi * np.asarray(f, float) / fs
    return (8.0 * np.sin(w_dt) - np.sin(2.0 * w_dt)) * (fs / 6.0)


def robust_deviation(a: np.ndarray) -> tuple[np.ndarray, float]:
    """Each sample's absolute deviation from the median of ``a``, and the robust scale
    ``1.4826 x`` their median (the standard deviation of Gaussian samples, which a few
    large ones barely move), in the unit of ``a``."""
    dev = np.abs(a - np.median(a))
    return dev, 1.4826 * float(np.median(dev))


def derivative(y: np.ndarray, fs: float) -> np.ndarray:
    """Time derivative of ``y`` sampled at ``fs`` [Hz]: five-point central difference
    (gain error ``(w dt)^4 / 30``), second-order at the ends."""
    y = np.asarray(y, float)
    d = np.gradient(y, 1.0 / fs)
    if y.size >= 5:
        d[2:-2] = (-y[4:] + 8.0 * y[3:-1] - 8.0 * y[1:-3] + y[:-4]) * (fs / 12.0)
    return d


def compare_velocity(
    v_channel: np.ndarray, v_x: np.ndarray, fs: float
) -> tuple[float, float, float]:
    """(gain error, lag [s], mismatch share) of a velocity channel against the
    derivative ``v_x`` of the displacement (both already band-limited alike):
    ``v_channel - v_x ~ a v_x + b dv_x/dt + c d2v_x/dt2`` by least squares; the lag is
    ``-b`` (a delay ``tau`` gives ``v(t - tau) ~ v - tau dv/dt``), the mismatch is
    ``RMS(b dv_x/dt + c d2v_x/dt2) / RMS(v_x)``, the part that depends on frequency (a
    pure gain error is taken up by the damping coefficient and names no element);
    samples with a difference beyond :data:`SPIKE_LIMIT` robust standard deviations are
    left out."""
    a_x = derivative(v_x, fs)
    j_x = derivative(a_x, fs)
    trim = slice(8, -8)  # the ends of a finite record carry the filters' edge effects
    basis = np.stack([v_x[trim], a_x[trim], j_x[trim]], axis=1)
    scale = np.sqrt(np.mean(basis**2, axis=0))
    scale[scale == 0] = 1.0
    diff = (v_channel - v_x)[trim]
    dev, spread = robust_deviation(diff)
    keep = dev <= SPIKE_LIMIT * spread if spread > 0 else slice(None)
    basis, diff = basis[keep], diff[keep]
    # a direction the motion does not excite (gain and curvature are one direction for
    # a single sine) is left out rather than split into large opposite coefficients
    coef, *_ = np.linalg.lstsq(basis / scale, diff, rcond=1e-6)
    coef = coef / scale
    dynamic = basis[:, 1:] @ coef[1:]  # what a gain cannot give: lag and curvature
    rms_v = float(np.sqrt(np.mean(v_x[trim] ** 2))) or 1.0
    return float(coef[0]), float(-coef[1]), float(np.sqrt(np.mean(dynamic**2))) / rms_v


def motion_versions(
    recordings: Sequence[RecordingLike], channels: Sequence[str]
) -> tuple[dict[str, list[RecordingLike]], list[MotionCheck]]:
    """Both processed versions of the recordings' motion (:func:`conditioned`, whose
    ``channels`` these are), ``{"band": [...], "displacement": [...]}``, and the checks,
    each recording's noise, cut-off and derivatives found once."""
    versions: dict[str, list[RecordingLike]] = {"band": [], "displacement": []}
    checks: list[MotionCheck] = []
    if len(channels) < 2:
        return {v: list(recordings) for v in versions}, checks
    xk, vk, *rest = channels
    for rec in recordings:
        fs = sampling_rate(np.asarray(rec.time, float))
        if fs is None or xk not in rec.inputs:
            for kept in versions.values():
                kept.append(rec)
            continue
        x = np.asarray(rec.inputs[xk], float)
        s2 = noise_variance(x, fs)
        fc = motion_cutoff(x, fs, s2)
        broadband = fc is None and noisy(x, s2)
        if broadband:
            fc = least_error_cutoff(x, fs, s2)
        rate, cut = fs, fc

        def band(y: np.ndarray, rate: float = rate, cut: float | None = cut) -> np.ndarray:
            return y if cut is None else lowpass(y, rate, cut)

        band_inputs = {**rec.inputs, xk: band(x)}
        derived_inputs = dict(band_inputs)
        d = band_inputs[xk]
        gain = lag = mismatch = None
        worst = noise = 0.0
        added = False
        for k, key in enumerate((vk, *rest)):
            d = derivative(d, fs)
            derived_inputs[key] = d
            if key not in rec.inputs:
                band_inputs[key], added = d, True
                continue
            recorded = band(np.asarray(rec.inputs[key], float))
            g, tau, mis = compare_velocity(recorded, d, fs)
            if k == 0:
                gain, lag, mismatch = g, tau, mis
            rms = float(np.sqrt(np.mean(d**2))) or 1.0
            worst = max(worst, mis)
            noise = max(noise, derivative_noise(s2, fs, fc, k + 1) / rms)
            band_inputs[key] = recorded
        sd, wide = float(np.sqrt(s2)), broadband and fc is not None
        checks.append(MotionCheck(str(rec.name), fc, gain, lag, mismatch, worst, noise, sd, wide))
        # nothing to remove and nothing added: the recording as it was
        clean = fc is None and not added
        versions["band"].append(rec if clean else replace(rec, inputs=band_inputs))  # type: ignore[type-var]
        versions["displacement"].append(replace(rec, inputs=derived_inputs))  # type: ignore[type-var]
    return versions, checks


def conditioned(
    recordings: Sequence[RecordingLike], channels: Sequence[str], version: str = "band"
) -> tuple[list[RecordingLike], list[MotionCheck]]:
    """The recordings with their motion channels in one ``version`` (module docstring).

    ``channels``: the model's motion inputs in order (displacement, velocity[,
    acceleration]), e.g. ``("displacement", "velocity")``. ``version``:
    ``"channel"``: as recorded; ``"band"``: every motion channel low-passed at the
    displacement's noise cut-off (a missing velocity or acceleration channel is the
    displacement's derivative); ``"displacement"``: the displacement low-passed, the
    velocity and acceleration its derivatives. The checks compare the recorded velocity
    (and acceleration) with the derivatives, for every version but ``"channel"``. A
    recording that is not uniformly sampled, lacks the displacement, or (``"band"``)
    holds clean channels with every rate recorded is returned as it was.
    """
    if version not in MOTION_VERSIONS:
        raise ValidationError(f"`version in {MOTION_VERSIONS}` must hold, but got {version!r}")
    if version == "channel":
        return list(recordings), []
    versions, checks = motion_versions(recordings, channels)
    return versions[version], checks


def derivative_noise(s2: float, fs: float, fc: float | None, order: int) -> float:
    """RMS noise [unit / s^order] that white noise of variance ``s2`` on a displacement
    leaves on its ``order``-th derivative (:func:`derivative`, applied ``order`` times)
    after the zero-phase low-pass at ``fc`` [Hz] (None: none): ``s2`` times the mean,
    over 0 to the Nyquist frequency, of the filter's power gain ``|H|^4`` and the
    five-point stencil's ``|D|^(2 order)``, ``D = (8 sin(w dt) - sin(2 w dt)) / (6 dt)``."""
    if s2 <= 0.0:
        return 0.0
    f = np.linspace(0.0, 0.5 * fs, 4097)[1:]
    gain = np.ones_like(f)
    if fc is not None:
        gain = np.abs(sosfreqz(butterworth(fc, fs), worN=f, fs=fs)[1]) ** 4
    return float(np.sqrt(s2 * np.mean(gain * _stencil(f, fs) ** (2 * order))))


def preferred_version(checks: Sequence[MotionCheck]) -> str | None:
    """The motion version to fit under ``"auto"``: ``"band"`` where no recorded rate has a
    frequency-dependent mismatch with the displacement's derivative (noise alone does not
    decide: an accelerometer may be cleaner than a twice-differentiated displacement),
    else ``"displacement"`` where the derivatives are clean (:data:`DERIVATIVE_CLEAN`),
    else None: the fit chooses (:func:`choice_words`)."""
    if not (bad := [c for c in checks if c.worst_mismatch > VELOCITY_MISMATCH]):
        return "band"
    if all(c.derivative_noise <= DERIVATIVE_CLEAN for c in bad):
        return "displacement"
    return None


def choice_words(checks: Sequence[MotionCheck], rms: Mapping[str, float], unit: str) -> str:
    """The sentence on the choice between the recorded rates and the displacement's
    derivatives, with each version's baseline residual RMS [``unit``]."""
    chosen = min(rms, key=lambda k: rms[k])
    what = {
        "band": "the recorded velocity (and acceleration) channels",
        "displacement": "the derivatives of the displacement",
    }
    names = ", ".join(c.recording for c in checks)
    return (
        f"motion of {names}: the baseline's residual is {rms['band']:.4g} {unit} RMS with "
        f"{what['band']} and {rms['displacement']:.4g} {unit} with {what['displacement']}: "
        f"{what[chosen]} are used (declare velocity_source to fix the choice)"
    )
