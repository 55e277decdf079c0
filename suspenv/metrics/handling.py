"""Handling metrics: pure functions from manoeuvre channels to numbers, and the slalom's.

Units are those of the channels passed in (the rigs use SI: m, s, rad). Arrays carry
samples on the first axis and the batch on the last axis.

Slalom (:func:`slalom`): measured over the middle cones (default the 3rd to the 8th) of
the rig's run (:func:`suspenv.rigs.handling.slalom_run`): for each cone the peak |yaw
rate| and peak |roll angle| while the vehicle is within half a spacing of the cone; the
results are the means of these peaks (mean yaw-rate amplitude, mean roll-angle
amplitude). The peaks are folded in step by step (:class:`WindowedPeaks`, handed to the
rig as its accumulator), so no time history is stored.

Linear-range slalom (:func:`slalom_linear`, the problem's default handling measures):
the same course followed exactly, evaluated by the linearised vehicle's frequency
response (:func:`suspenv.models.minibus.handling_model.steer_response`, ISO 7401's
frequency-response quantities) at the course's frequency ``u / (2 s)``: the path's
lateral acceleration amplitude ``A (pi u / s)^2`` divided by the lateral-acceleration
gain gives the road-wheel steer the course needs, times the steering ratio the
steering-wheel angle (GB/T 6323.1's second slalom index, the "average steering-wheel
angle peak"); the roll and yaw-rate amplitudes follow from their gains. No time loop:
one 4x4 complex solve per design.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.minibus import handling_kernel
from suspenv.models.minibus.handling_model import (
    HandlingParams,
    linear_system,
    steer_response,
)
from suspenv.rigs.handling import (
    SLALOM_SIGNALS,
    SlalomConfig,
    SlalomRun,
    SteadyCircleConfig,
    secant_axle_stiffness,
    slalom_run,
)


class WindowedPeaks:
    """Running peak |signal| per position window, updated sample by sample for a batch.

    Window k covers ``centres[k] - half_width <= x < centres[k] + half_width``; the
    windows must not overlap. Used by the slalom to measure the peak of each
    half-cycle around each cone without storing the time histories. Several signals
    (``n_signals``) share the positions and are updated together.
    """

    def __init__(self, centres: np.ndarray, half_width: float, n: int, n_signals: int = 1):
        c = np.asarray(centres, dtype=float)
        if c.ndim != 1 or c.size == 0:
            raise ValidationError(f"`centres` must be a non-empty 1-D array, but got {c.shape}")
        if half_width <= 0:
            raise ValidationError(f"`half_width > 0` must hold, but got half_width={half_width}")
        if c.size > 1 and np.min(np.diff(c)) < 2.0 * half_width - 1e-9:
            raise ValidationError(
                "windows must not overlap: `diff(centres) >= 2 half_width` must hold, but got "
                f"(min spacing={np.min(np.diff(c))}, half_width={half_width})"
            )
        self.centres = c
        self.half_width = float(half_width)
        # last window row collects the samples outside every window
        self.peaks = np.zeros((n_signals, c.size + 1, n))
        self._cols = np.arange(n)
        self._starts = c - self.half_width
        self._ends = c + self.half_width

    def update(self, x: np.ndarray, values: np.ndarray) -> None:
        """Fold one sample in: positions ``x`` (n,), values (n_signals, n) or (n,)."""
        vals = np.abs(np.asarray(values, dtype=float)).reshape(self.peaks.shape[0], -1)
        k = np.searchsorted(self._starts, x, side="right") - 1
        inside = (k >= 0) & (x < self._ends[np.clip(k, 0, None)])
        k = np.where(inside, k, self.centres.size)
        cur = self.peaks[:, k, self._cols]
        self.peaks[:, k, self._cols] = np.maximum(cur, vals)

    def result(self, signal: int = 0) -> np.ndarray:
        """(n_windows, n) peak |value| of one signal in every window."""
        return self.peaks[signal, :-1].copy()


def mean_peak_amplitude(peaks: np.ndarray) -> np.ndarray:
    """Mean over windows (axis 0) of per-window peak amplitudes."""
    peaks = np.asarray(peaks, dtype=float)
    if peaks.ndim < 1 or peaks.shape[0] == 0:
        raise ValidationError(f"`peaks` needs at least one window, but got shape {peaks.shape}")
    return peaks.mean(axis=0)


# ------------------------------------------------------------------ slalom
@dataclass(kw_only=True)
class SlalomResult(SlalomRun):
    """Slalom results of a batch: the run's (:class:`suspenv.rigs.handling.SlalomRun`:
    path error, completion, settings, channels) and its measures.

    Attributes:
        yaw_rate_amplitude: rad/s (n,), mean of the per-cone peaks |r|.
        roll_amplitude: rad (n,), mean of the per-cone peaks |phi|.
        steer_amplitude: rad (n,), road-wheel steer, same windows.
        ay_amplitude: m/s^2 (n,), same windows.
        yaw_rate_peaks, roll_peaks: (n_measured_cones, n) the per-cone peaks.
    """

    yaw_rate_amplitude: np.ndarray
    roll_amplitude: np.ndarray
    steer_amplitude: np.ndarray
    ay_amplitude: np.ndarray
    yaw_rate_peaks: np.ndarray
    roll_peaks: np.ndarray


def slalom(
    P: HandlingParams, config: SlalomConfig | None = None, side: float = 1.0
) -> SlalomResult:
    """Run the pylon-course slalom for every row of ``P`` and measure it (module docstring)."""
    config = config or SlalomConfig()
    first, stop = config.measure_cones
    peaks = WindowedPeaks(
        config.cone_x[first:stop], 0.5 * config.spacing, P.n, n_signals=len(SLALOM_SIGNALS)
    )
    run = slalom_run(P, config, side, accumulator=peaks)
    r_peaks = peaks.result(SLALOM_SIGNALS.index("yaw_rate"))
    phi_peaks = peaks.result(SLALOM_SIGNALS.index("roll"))
    return SlalomResult(
        **vars(run),
        yaw_rate_amplitude=mean_peak_amplitude(r_peaks),
        roll_amplitude=mean_peak_amplitude(phi_peaks),
        steer_amplitude=mean_peak_amplitude(peaks.result(SLALOM_SIGNALS.index("steer"))),
        ay_amplitude=mean_peak_amplitude(peaks.result(SLALOM_SIGNALS.index("ay"))),
        yaw_rate_peaks=r_peaks,
        roll_peaks=phi_peaks,
    )


# ------------------------------------------------------------------ linear-range slalom
@dataclass
class SlalomLinearResult:
    """Linear-range slalom of a batch (module docstring), arrays (n,).

    Attributes:
        steering_wheel_amplitude: rad, steering-wheel angle amplitude the course needs
            (road-wheel steer times the vehicle's steering ratio).
        steer_amplitude: rad, front road-wheel steer amplitude.
        yaw_rate_amplitude: rad/s; roll_amplitude: rad; ay_amplitude: m/s^2 (the path's).
        yaw_rate_gain: 1/s, yaw rate per rad of steering-wheel angle at the course's
            frequency; frequency: Hz.
        stable: bool, every pole of the linearised vehicle in the left half-plane (an
            unstable row's numbers are meaningless: the problem fails it).
    """

    steering_wheel_amplitude: np.ndarray
    steer_amplitude: np.ndarray
    yaw_rate_amplitude: np.ndarray
    roll_amplitude: np.ndarray
    ay_amplitude: np.ndarray
    yaw_rate_gain: np.ndarray
    frequency: float
    stable: np.ndarray


def course_lateral_acceleration(config: SlalomConfig) -> float:
    """Lateral acceleration amplitude (m/s^2) of the course's path: ``A (pi u / s)^2``."""
    return float(config.amplitude * (np.pi * config.speed / config.spacing) ** 2)


def slalom_linear(
    P: HandlingParams,
    config: SlalomConfig | None = None,
    circle: SteadyCircleConfig | None = None,
    working_point: bool = True,
    system: tuple[np.ndarray, np.ndarray] | None = None,
    stable: np.ndarray | None = None,
) -> SlalomLinearResult:
    """The slalom course followed exactly by the linearised vehicle (module docstring).

    ``working_point=True`` (default): the axles' tyres at their quasi-steady secant
    stiffness at the course's lateral acceleration amplitude
    (:func:`course_lateral_acceleration`, 3.8 m/s^2 = 0.39 g at 60 km/h and 30 m; by
    :func:`suspenv.rigs.handling.secant_axle_stiffness`), so the load transfer (the
    stabiliser bars' balance), the tyres' load sensitivity and the compliances enter
    as they do where the course runs; ``False``: the small-amplitude linearisation
    about straight running (the bars' split then only moves the roll steer).
    ``system``: (A, B) of :func:`linear_system` at the course's speed and working point,
    if already at hand; ``stable``: whether each row of that A is finite with every pole
    in the left half-plane, if already known (else from A's eigenvalues).
    """
    config = config or SlalomConfig()
    u = config.speed
    f = u / (2.0 * config.spacing)  # one cycle per two cones
    ay = course_lateral_acceleration(config)
    if system is None:
        stiffness = secant_axle_stiffness(P, ay, circle) if working_point else None
        system = linear_system(P, u, stiffness)
    A, B = system
    H = steer_response(P, u, f, (A, B))
    steer = ay / np.abs(H.ay[:, 0])
    yaw_gain = np.abs(H.yaw_rate[:, 0])
    ratio = P.vehicle.steering_ratio
    if stable is None:
        with np.errstate(invalid="ignore"):
            poles = np.linalg.eigvals(np.nan_to_num(A, nan=1.0))
        stable = np.all(poles.real < 0, axis=-1) & np.isfinite(A).all(axis=(1, 2))
    return SlalomLinearResult(
        steering_wheel_amplitude=ratio * steer,
        steer_amplitude=steer,
        yaw_rate_amplitude=steer * yaw_gain,
        roll_amplitude=steer * np.abs(H.roll[:, 0]),
        ay_amplitude=np.full(P.n, ay),
        yaw_rate_gain=yaw_gain / ratio,
        frequency=f,
        stable=stable,
    )


# ------------------------------------------------------------------ ISO 7401
@dataclass
class YawResponse:
    """ISO 7401 yaw-rate response of a linear handling system (arrays (n,)).

    Attributes:
        gain: 1/s, steady yaw rate per rad of road-wheel steer.
        response_time: s, from a steer step to 90 % of the steady yaw rate (ISO 7401's
            response time, measured from 50 % of the steer input: an ideal step).
        peak_time: s, to the yaw rate's first peak (``t_end`` when it has none).
        overshoot: -, peak yaw rate over the steady one, minus 1 (0 without a peak).
        bandwidth: Hz, lowest frequency at which the yaw-rate gain has fallen to
            ``1/sqrt(2)`` of the steady gain (``f_max`` where it has not).
    """

    gain: np.ndarray
    response_time: np.ndarray
    peak_time: np.ndarray
    overshoot: np.ndarray
    bandwidth: np.ndarray


def yaw_response(
    A: np.ndarray,
    B: np.ndarray,
    t_end: float = 3.0,
    dt: float = 0.01,
    f_max: float = 5.0,
    modes: tuple[np.ndarray, np.ndarray] | None = None,
) -> YawResponse:
    """Step and frequency response of the yaw rate of the linear system ``(A, B)``
    (:func:`linear_system`, state (v, r, phi, p), unit road-wheel steer), in closed form
    through the eigen-decomposition ``A = V diag(lam) V^-1``: with ``w = (V^-1 B)_k
    V[r, k] / lam_k``, the step response is ``r(t) = sum_k w_k (e^(lam_k t) - 1)`` and
    the frequency response ``H(f) = sum_k w_k lam_k / (i 2 pi f - lam_k)``. The 90 %
    crossing and the first peak are found on a grid of ``dt`` (s) up to ``t_end`` and
    refined by Newton steps on the closed form, the bandwidth on a log grid to ``f_max``
    (Hz) refined by regula falsi in log f (both to round-off; the compiled
    :func:`suspenv.models.minibus.handling_kernel.yaw_loop`, ``x(inf) = -A^-1 B`` the
    steady state). Rows must be stable. ``modes``: ``np.linalg.eig(A)`` if already at
    hand."""
    lam, V = modes if modes is not None else np.linalg.eig(A)
    out = np.empty((A.shape[0], 6))
    lam, V = np.ascontiguousarray(lam, dtype=complex), np.ascontiguousarray(V, dtype=complex)
    B = np.ascontiguousarray(B, dtype=float)
    handling_kernel.yaw_loop(lam, V, B, _grid(t_end, dt), _log_grid(f_max), float(f_max), out)
    has_peak = out[:, 2] > 0
    return YawResponse(
        gain=out[:, 5],
        response_time=out[:, 0],
        peak_time=np.where(has_peak, out[:, 1], t_end),
        overshoot=np.where(has_peak, np.maximum(out[:, 3] - 1.0, 0.0), 0.0),
        bandwidth=out[:, 4],
    )


@functools.lru_cache(maxsize=4)
def _grid(t_end: float, dt: float) -> np.ndarray:
    """Times 0, dt, .. t_end (s) of the step response's search grid (read-only, cached)."""
    t = np.arange(0.0, t_end + 0.5 * dt, dt)
    t.flags.writeable = False
    return t


@functools.lru_cache(maxsize=4)
def _log_grid(f_max: float) -> np.ndarray:
    """48 log-spaced frequencies 0.01..``f_max`` Hz (read-only, cached)."""
    f = np.geomspace(0.01, f_max, 48)
    f.flags.writeable = False
    return f
