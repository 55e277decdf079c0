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
  white noise of the level seen above ``0.8 f_Nyquist`` would give. A clean recording
  (noise below :data:`NEGLIGIBLE_NOISE` of the motion) keeps every sample.
* **a velocity channel that is a filtered derivative of the displacement** (a
  Savitzky-Golay or a causal differentiator in the rig's software): it lags or is
  attenuated at the higher test frequencies, and a frequency-dependent force error looks
  like viscoelastic damping. The channel is compared with the derivative of the
  displacement over the motion band: ``v_channel - v_x`` regressed on ``v_x`` (a gain
  error), its time derivative (a lag, positive when the channel lags) and its second
  derivative (a curvature of the gain with frequency); a lag and curvature part above
  :data:`VELOCITY_MISMATCH` of the velocity's RMS means the channel is not the
  displacement's derivative, and the derivative is used (``velocity_source = "auto"``).

``velocity_source`` (rig description, :mod:`suspenv.diagnosis.component.rig`):
``"auto"`` (above), ``"displacement"`` (always the derivative of the displacement),
``"channel"`` (the channels exactly as recorded: no low-pass, no check).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import butter, sosfiltfilt, sosfreqz

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.protocols import RecordingLike

VELOCITY_SOURCES = ("auto", "displacement", "channel")
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
#: rounding of a synthetic signal, the filter's own start-up ringing (a 16-bit
#: transducer's quantisation noise is about 1.2e-5 of a sine's standard deviation
#: spanning its range, and harmless to a fit)
NEGLIGIBLE_NOISE = 1e-5
#: fewest samples for the noise estimate and the comparison
MIN_SAMPLES = 256
BUTTER_ORDER = 4


@dataclass(frozen=True)
class MotionCheck:
    """What was done to one recording's motion channels.

    Attributes:
        recording: recording name.
        cutoff_hz: low-pass cut-off [Hz] applied to the motion channels (None: none).
        gain_error: ``g - 1`` of the velocity channel against the derivative (None: no
            velocity channel or no check).
        lag_s: delay of the velocity channel behind the derivative [s] (positive: lags).
        mismatch: RMS of the fitted difference / RMS of the velocity (None: no check).
        velocity_from: ``"channel"`` or ``"displacement"``: which velocity the fit uses.
    """

    recording: str
    cutoff_hz: float | None
    gain_error: float | None
    lag_s: float | None
    mismatch: float | None
    velocity_from: str

    def words(self) -> list[str]:
        """Sentences for the report's evidence."""
        out = []
        if self.cutoff_hz is not None:
            out.append(
                f"recording {self.recording}: motion channels low-passed at "
                f"{self.cutoff_hz:.3g} Hz (zero phase; what lies above it is white noise)"
            )
        if self.velocity_from == "displacement" and self.mismatch is not None:
            lag = "" if self.lag_s is None else f", lag {1e3 * self.lag_s:+.3g} ms"
            gain = "" if self.gain_error is None else f"gain {100 * self.gain_error:+.2g} %"
            out.append(
                f"recording {self.recording}: the velocity channel is not the derivative of "
                f"the displacement ({gain}{lag}; {100 * self.mismatch:.2g} % of its RMS, a "
                "filtered derivative): the derivative of the displacement is used "
                '(declare velocity_source = "channel" to keep the channel)'
            )
        return out


def _sampling(t: np.ndarray) -> float | None:
    """The sampling rate [Hz] of a uniformly sampled time axis, else None."""
    dt = np.diff(t)
    if dt.size < MIN_SAMPLES or not np.all(dt > 0):
        return None
    step = float(np.median(dt))
    if float(np.max(np.abs(dt - step))) > 0.01 * step:
        return None
    return 1.0 / step


def lowpass(y: np.ndarray, fs: float, fc: float) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``y`` at ``fc`` [Hz] (order 4 each way)."""
    sos = butter(BUTTER_ORDER, fc, fs=fs, output="sos")
    return np.asarray(sosfiltfilt(sos, y))


def _removed_share(fs: float, fc: float) -> float:
    """Share of white-noise variance that ``y - lowpass(y, fc)`` keeps."""
    sos = butter(BUTTER_ORDER, fc, fs=fs, output="sos")
    _, h = sosfreqz(sos, worN=4096, fs=fs)
    return float(np.mean((1.0 - np.abs(h) ** 2) ** 2))


def motion_cutoff(x: np.ndarray, fs: float) -> float | None:
    """The low-pass cut-off [Hz] that removes white noise and nothing of the motion, or
    None when no cut-off removes noise alone (clean data, or a broadband motion)."""
    x = np.asarray(x, float)
    nyq = 0.5 * fs

    def removed(fc: float) -> float:
        # variance of what the filter removes, a few periods of the cut-off away from
        # the record's ends (the filter's start-up transients; at most 5 % of the
        # samples each side, so that no part of the test is left out)
        k = min(int(np.ceil(3.0 * fs / fc)), x.size // 20)
        return float(np.var((x - lowpass(x, fs, fc))[k : x.size - k]))

    top = NOISE_BAND * nyq
    s2 = removed(top) / _removed_share(fs, top)
    if not s2 > (NEGLIGIBLE_NOISE * float(np.std(x))) ** 2:
        return None
    chosen = None
    for frac in CUTOFF_GRID:
        fc = frac * nyq
        if removed(fc) > NOISE_TOLERANCE * s2 * _removed_share(fs, fc):
            break
        chosen = fc
    if chosen is None or chosen >= CUTOFF_GRID[0] * nyq:
        return None
    return chosen


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
    spread = 1.4826 * float(np.median(np.abs(diff - np.median(diff))))
    keep = np.abs(diff - np.median(diff)) <= SPIKE_LIMIT * spread if spread > 0 else slice(None)
    basis, diff = basis[keep], diff[keep]
    coef, *_ = np.linalg.lstsq(basis / scale, diff, rcond=None)
    coef = coef / scale
    dynamic = basis[:, 1:] @ coef[1:]  # what a gain cannot give: lag and curvature
    rms_v = float(np.sqrt(np.mean(v_x[trim] ** 2))) or 1.0
    return float(coef[0]), float(-coef[1]), float(np.sqrt(np.mean(dynamic**2))) / rms_v


def conditioned(
    recordings: Sequence[RecordingLike],
    channels: Sequence[str],
    velocity_source: str = "auto",
) -> tuple[list[RecordingLike], list[MotionCheck]]:
    """The recordings with their motion channels conditioned (module docstring).

    ``channels``: the model's motion inputs in order (displacement, velocity[,
    acceleration]), e.g. ``("displacement", "velocity")``; a recording lacking one is
    left as it is, as is every recording for ``velocity_source = "channel"``.
    """
    if velocity_source not in VELOCITY_SOURCES:
        raise ValidationError(
            f"`velocity_source in {VELOCITY_SOURCES}` must hold, but got {velocity_source!r}"
        )
    if velocity_source == "channel" or len(channels) < 2:
        return list(recordings), []
    xk, vk, *rest = channels
    out: list[RecordingLike] = []
    checks: list[MotionCheck] = []
    for rec in recordings:
        fs = _sampling(np.asarray(rec.time, float))
        if fs is None or xk not in rec.inputs:
            out.append(rec)
            continue
        x = np.asarray(rec.inputs[xk], float)
        fc = motion_cutoff(x, fs)
        rate, cut = fs, fc

        def band(y: np.ndarray, rate: float = rate, cut: float | None = cut) -> np.ndarray:
            return y if cut is None else lowpass(y, rate, cut)

        x_f = band(x)
        v_x = derivative(x_f, fs)
        inputs = dict(rec.inputs)
        inputs[xk] = x_f
        gain = lag = mismatch = None
        use = "displacement"
        if vk in rec.inputs and velocity_source == "auto":
            v_f = band(np.asarray(rec.inputs[vk], float))
            gain, lag, mismatch = compare_velocity(v_f, v_x, fs)
            if mismatch <= VELOCITY_MISMATCH:
                use = "channel"
                inputs[vk] = v_f
        if use == "displacement":
            inputs[vk] = v_x
        for ak in rest:
            if ak in rec.inputs:
                inputs[ak] = (
                    derivative(v_x, fs)
                    if use == "displacement"
                    else band(np.asarray(rec.inputs[ak], float))
                )
        check = MotionCheck(str(rec.name), fc, gain, lag, mismatch, use)
        if fc is None and use == "channel":
            out.append(rec)  # nothing changed: the recording as it was
        else:
            out.append(replace(rec, inputs=inputs))  # type: ignore[type-var]
        checks.append(check)
    return out, checks
