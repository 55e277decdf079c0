"""Signature detectors: one per family of left-out physics.

Each detector builds a small set of *signature features* from the measured motion
(and the baseline prediction) and asks how much of the baseline residual they
explain **beyond what the baseline parameters could already absorb**: features are
first projected onto the orthogonal complement of the baseline Jacobian columns,
then the residual is regressed on them. The score is that partial R² in [0, 1] (the
share of residual energy the signature explains); ``n R²`` is the Lagrange-multiplier
(score) statistic of adding the effect, turned into a p-value with the effective sample
size of the serially correlated residual (:mod:`~suspenv.diagnosis.screening`).

Signatures (residual = measured - baseline prediction):

=================  =====================================================================
friction           a step at every velocity reversal: tanh(v / v_s), v_s = 1 % of max|v|
hysteresis         a loop that settles over a displacement after each reversal, the same
                   at any rate: unit Dahl state along x (transition 3-30 % of half-stroke)
spring             in phase with displacement: k x (parallel or gas spring)
progressive        odd-symmetric, growing faster than x: x³ (3rd harmonic of a sine)
end_stop           only beyond a travel threshold: max(x - x_th, 0) or min(...), or both
                   sides with their own thresholds when the second ramp is significant
damper_asymmetry   depends on the sign of velocity, even in v: |v| (bump != rebound slope)
digressive         odd in v, slope falling with speed: sign(v) min(|v|, v_k)
viscoelastic       rate-dependent lag: first-order low-pass of the velocity (Maxwell)
sensor_offset      a constant
sensor_gain        proportional to the predicted signal
sensor_lag         proportional to the predicted signal's time derivative (phase shift)
=================  =====================================================================

Units: ``x`` [m] (positive = compression / bump), ``v`` [m/s], ``t`` [s]; residuals
are passed divided by their channel scale, and evidence numbers are converted back
to the channel unit with ``scale``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from suspenv.diagnosis.component.locate import dominant_frequency, reversal_indices
from suspenv.diagnosis.screening import Signature, orthonormal_basis, partial_r2, score_p_value


@dataclass
class SignalSet:
    """Samples one detector looks at; 1-D arrays of equal length, segments stacked.

    Attributes:
        t, x, v: time [s], deflection [m], velocity [m/s].
        residual: scaled residual (measured - predicted) / scale.
        prediction: scaled baseline prediction.
        jacobian: (n, p) d(scaled prediction)/d(theta) rows aligned with the samples, or None.
        segment: (n,) integer segment id (features with state restart at each segment).
        scale: channel scale (channel unit) to express evidence in physical units.
        unit: the channel unit, e.g. "N".
        channel: the channel name.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    residual: np.ndarray
    prediction: np.ndarray
    jacobian: np.ndarray | None = None
    segment: np.ndarray | None = None
    scale: float = 1.0
    unit: str = ""
    channel: str = ""

    def segments(self) -> list[np.ndarray]:
        seg = self.segment if self.segment is not None else np.zeros(self.t.size, int)
        return [np.flatnonzero(seg == s) for s in np.unique(seg)]


# ------------------------------------------------------------------ helpers
def _per_segment(
    s: SignalSet, fn: Callable[[np.ndarray, float], np.ndarray], par: float
) -> np.ndarray:
    """Apply a feature builder ``fn(segment indices, par)`` segment by segment (states
    restart) and stack."""
    out = np.zeros(s.t.size)
    for idx in s.segments():
        out[idx] = fn(idx, par)
    return out


def unit_dahl(x: np.ndarray, delta: float) -> np.ndarray:
    """Dahl state with unit saturation force and transition displacement ``delta`` [m]."""
    z = np.zeros(x.size)
    dx = np.diff(x)
    decay = np.exp(-np.abs(dx) / delta)
    s = np.sign(dx)
    zk = 0.0
    for k in range(dx.size):
        zk = s[k] + (zk - s[k]) * decay[k]
        z[k + 1] = zk
    return z


def first_order_lowpass(u: np.ndarray, t: np.ndarray, tau: float) -> np.ndarray:
    """y' = (u - y) / tau, y(0) = u(0); exact for piecewise-constant input at the mean step."""
    dt = float(np.mean(np.diff(t))) if t.size > 1 else 1.0
    a = float(np.exp(-dt / tau))
    y, _ = lfilter([1.0 - a], [1.0, -a], u[1:], zi=[a * u[0]])
    return np.concatenate([[u[0]], y])


def _best_of(
    s: SignalSet, basis: np.ndarray | None, candidates: Sequence[tuple[float, np.ndarray]]
) -> tuple[float, float, np.ndarray, np.ndarray]:
    """Best single feature of a scan: (parameter, r2, coefficients, fitted part)."""
    best = (float("nan"), 0.0, np.zeros(1), np.zeros_like(s.residual))
    for par, feat in candidates:
        r2, coef, fitted = partial_r2(s.residual, feat[:, None], basis)
        if r2 > best[1]:
            best = (par, r2, coef, fitted)
    return best


def _scored(
    kind: str,
    s: SignalSet,
    r2: float,
    fitted: np.ndarray,
    words: str,
    numbers: dict[str, float],
    q: int = 1,
) -> Signature:
    """The signature of ``kind`` with score ``r2`` of ``q`` features (its p-value from
    what their ``fitted`` part leaves of the residual), evidence ``words``, ``numbers``
    and ``r2``."""
    p = score_p_value(r2, s.residual - fitted, q=q)
    return Signature(kind, r2, p, words, {**numbers, "r2": r2})


# ---------------------------------------------------------------- detectors
def detect_friction(s: SignalSet, basis: np.ndarray | None) -> Signature:
    vmax = float(np.max(np.abs(s.v))) or 1.0
    feat = np.tanh(s.v / (0.01 * vmax))
    r2, coef, fitted = partial_r2(s.residual, feat[:, None], basis)
    n_rev = int(sum(reversal_indices(s.v[idx]).size for idx in s.segments()))
    step = 2.0 * abs(coef[0]) * s.scale
    words = (
        f"residual steps by {step:.3g} {s.unit} at each of the {n_rev} velocity reversals "
        f"(a sign(v) term explains {100 * r2:.0f} % of the residual energy)"
    )
    return _scored("friction", s, r2, fitted, words, {"step": step, "n_reversals": float(n_rev)})


def detect_hysteresis(s: SignalSet, basis: np.ndarray | None) -> Signature:
    half = 0.5 * float(np.ptp(s.x)) or 1.0
    cands = []
    for frac in (0.03, 0.1, 0.3):
        feat = _per_segment(s, lambda idx, d: unit_dahl(s.x[idx], d), frac * half)
        cands.append((frac, feat))
    frac, r2, coef, fitted = _best_of(s, basis, cands)
    width = 2.0 * abs(coef[0]) * s.scale
    words = (
        f"a loop {width:.3g} {s.unit} wide that settles within {100 * frac:.0f} % of the "
        f"half-stroke after each reversal, set by displacement not rate "
        f"(explains {100 * r2:.0f} %)"
    )
    return _scored(
        "hysteresis", s, r2, fitted, words, {"loop_width": width, "transition_fraction": frac}
    )


def detect_progressive(s: SignalSet, basis: np.ndarray | None) -> Signature:
    # the stiffening is odd about the element's own zero: the static position (x = 0)
    # where the deflection is measured from equilibrium, else the middle of the stroke
    half = 0.5 * float(np.ptp(s.x)) or 1.0
    centres = [0.5 * (np.max(s.x) + np.min(s.x))]
    if np.min(s.x) < 0.0 < np.max(s.x):
        centres.append(0.0)
    cands = [(c, ((s.x - c) / half) ** 3) for c in centres]
    centre, r2, coef, fitted = _best_of(s, basis, cands)
    if not np.isfinite(centre):
        centre, coef, fitted = centres[0], np.zeros(1), np.zeros_like(s.residual)
    f0 = dominant_frequency(s.t, s.x)
    h3 = float("nan")
    if np.isfinite(f0) and f0 > 0:
        dt = float(np.median(np.diff(s.t)))
        p = np.abs(np.fft.rfft(s.residual)) ** 2
        fr = np.fft.rfftfreq(s.t.size, dt) / f0
        total = float(np.sum(p)) or 1.0
        h3 = float(np.sum(p[(fr > 2.5) & (fr < 3.5)]) / total)
    extra = abs(coef[0]) * s.scale
    words = (
        f"odd residual growing with amplitude, {extra:.3g} {s.unit} extra at full stroke; "
        f"{100 * h3:.0f} % of the residual energy at 3x the excitation frequency "
        f"(x³ explains {100 * r2:.0f} %)"
    )
    numbers = {"extra_at_full_stroke": extra, "third_harmonic_share": h3}
    return _scored("progressive", s, r2, fitted, words, numbers)


def detect_spring(s: SignalSet, basis: np.ndarray | None) -> Signature:
    half = 0.5 * float(np.ptp(s.x)) or 1.0
    r2, coef, fitted = partial_r2(s.residual, (s.x / half)[:, None], basis)
    k = coef[0] * s.scale / half
    words = (
        f"residual in phase with displacement: a parallel (gas) spring of about {k:.3g} "
        f"{s.unit}/m (explains {100 * r2:.0f} %)"
    )
    return _scored("spring", s, r2, fitted, words, {"stiffness": k})


#: a second ramp (the other side's stop) is reported when the share of what the best
#: one-sided ramp leaves that it explains has a score-test p-value below this
END_STOP_SECOND_SIDE_P = 1e-3
END_STOP_QUANTILES = (0.7, 0.8, 0.9, 0.95)


def detect_end_stop(s: SignalSet, basis: np.ndarray | None) -> Signature:
    """Ramps beyond a travel threshold: the best one-sided ramp over the thresholds at the
    ``END_STOP_QUANTILES`` of ``x``, then the best pair (one threshold per side); the
    pair is the signature when its second ramp is significant (``END_STOP_SECOND_SIDE_P``).
    Thresholds [m] in the deflection frame: compression beyond ``threshold_bump_m``,
    extension below ``threshold_rebound_m``."""
    highs = [float(np.quantile(s.x, q)) for q in END_STOP_QUANTILES]
    lows = [float(np.quantile(s.x, 1.0 - q)) for q in END_STOP_QUANTILES]
    cands = []
    for hi, lo in zip(highs, lows, strict=True):
        cands.append((hi, np.maximum(s.x - hi, 0.0)))
        cands.append((lo, np.minimum(s.x - lo, 0.0)))
    thr, r2, coef, fitted = _best_of(s, basis, cands)
    pair = (float("nan"), float("nan"), r2, fitted)
    for hi in highs:
        for lo in lows:
            feats = np.column_stack([np.maximum(s.x - hi, 0.0), np.minimum(s.x - lo, 0.0)])
            r2_pair, _, fitted_pair = partial_r2(s.residual, feats, basis)
            if r2_pair > pair[2]:
                pair = (hi, lo, r2_pair, fitted_pair)
    gain = (pair[2] - r2) / max(1.0 - r2, 1e-12)
    both = (
        np.isfinite(thr)
        and np.isfinite(pair[0])
        and gain > 0.0
        and score_p_value(gain, s.residual - pair[3]) < END_STOP_SECOND_SIDE_P
    )
    if both:
        hi, lo, r2, fitted = pair
        beyond = (s.x > hi) | (s.x < lo)
        where = f"{1e3 * hi:.3g} mm in compression and beyond {1e3 * lo:.3g} mm in extension"
        words, sides = ("hold", "a ramp on each side"), 2
        thresholds = {
            "threshold_m": hi if abs(hi) >= abs(lo) else lo,
            "threshold_bump_m": hi,
            "threshold_rebound_m": lo,
        }
        one_side: dict[str, float] = {}
    else:
        side = "compression" if np.isfinite(thr) and thr >= np.median(s.x) else "extension"
        beyond = s.x > thr if side == "compression" else s.x < thr  # none where thr is NaN
        where = f"{1e3 * thr:.3g} mm on the {side} side"
        words, sides = ("holds", "a one-sided ramp"), 1
        thresholds = {"threshold_m": thr}
        key = "threshold_bump_m" if side == "compression" else "threshold_rebound_m"
        one_side = {key: thr} if np.isfinite(thr) else {}
    share = float(np.sum(s.residual[beyond] ** 2) / (float(np.sum(s.residual**2)) or 1.0))
    frac = float(np.mean(beyond))
    said = (
        f"{100 * share:.0f} % of the residual energy lies beyond {where}, which {words[0]} "
        f"{100 * frac:.0f} % of the samples ({words[1]} explains {100 * r2:.0f} %)"
    )
    numbers = {"sides": float(sides), "share_beyond": share, "fraction_beyond": frac}
    return _scored("end_stop", s, r2, fitted, said, {**thresholds, **numbers, **one_side}, sides)


def detect_damper_asymmetry(s: SignalSet, basis: np.ndarray | None) -> Signature:
    vmax = float(np.max(np.abs(s.v))) or 1.0
    r2, coef, fitted = partial_r2(s.residual, (np.abs(s.v) / vmax)[:, None], basis)
    d = coef[0] * s.scale
    words = (
        f"residual has the same sign in bump and rebound and grows with speed: "
        f"{d:+.3g} {s.unit} at max |v| = {vmax:.3g} m/s, i.e. bump and rebound slopes differ "
        f"(|v| explains {100 * r2:.0f} %)"
    )
    return _scored("damper_asymmetry", s, r2, fitted, words, {"even_part_at_vmax": d})


def detect_digressive(s: SignalSet, basis: np.ndarray | None) -> Signature:
    vmax = float(np.max(np.abs(s.v))) or 1.0
    cands = [
        (frac, np.sign(s.v) * np.minimum(np.abs(s.v), frac * vmax) / (frac * vmax))
        for frac in (0.1, 0.25, 0.5)
    ]
    frac, r2, coef, fitted = _best_of(s, basis, cands)
    words = (
        f"odd residual in velocity whose slope falls above about {frac * vmax:.3g} m/s "
        f"(a knee in the force-velocity curve; explains {100 * r2:.0f} %)"
    )
    return _scored("digressive", s, r2, fitted, words, {"knee_velocity": frac * vmax})


def detect_viscoelastic(s: SignalSet, basis: np.ndarray | None) -> Signature:
    f0 = dominant_frequency(s.t, s.x)
    w0 = 2 * np.pi * (f0 if np.isfinite(f0) and f0 > 0 else 1.0)
    vmax = float(np.max(np.abs(s.v))) or 1.0

    def lagged(idx: np.ndarray, tau: float) -> np.ndarray:
        return first_order_lowpass(s.v[idx], s.t[idx], tau) / vmax

    cands = [(wt / w0, _per_segment(s, lagged, wt / w0)) for wt in np.geomspace(0.01, 3.0, 8)]
    tau, r2, _, fitted = _best_of(s, basis, cands)
    words = (
        f"a lagged, rate-dependent force (relaxation time about {tau:.3g} s; the loop width "
        f"changes with frequency; explains {100 * r2:.0f} %)"
    )
    return _scored("viscoelastic", s, r2, fitted, words, {"relaxation_time_s": tau})


def detect_sensor_offset(s: SignalSet, basis: np.ndarray | None) -> Signature:
    r2, coef, fitted = partial_r2(s.residual, np.ones((s.t.size, 1)), basis)
    off = coef[0] * s.scale
    words = f"constant residual of {off:+.3g} {s.unit} (explains {100 * r2:.0f} %)"
    return _scored("sensor_offset", s, r2, fitted, words, {"offset": off})


def detect_sensor_gain(s: SignalSet, basis: np.ndarray | None) -> Signature:
    r2, coef, fitted = partial_r2(s.residual, s.prediction[:, None], basis)
    words = (
        f"residual proportional to the signal: gain error {100 * coef[0]:+.2g} % "
        f"(explains {100 * r2:.0f} %)"
    )
    return _scored("sensor_gain", s, r2, fitted, words, {"gain_error": float(coef[0])})


def detect_sensor_lag(s: SignalSet, basis: np.ndarray | None) -> Signature:
    dydt = np.zeros(s.t.size)
    for idx in s.segments():
        if idx.size > 2:
            dydt[idx] = np.gradient(s.prediction[idx], s.t[idx])
    r2, coef, fitted = partial_r2(s.residual, dydt[:, None], basis)
    lag = -float(coef[0])
    words = (
        f"residual follows the signal's rate of change: a phase shift of about "
        f"{1e3 * lag:.3g} ms (explains {100 * r2:.0f} %)"
    )
    return _scored("sensor_lag", s, r2, fitted, words, {"lag_s": lag})


DETECTORS: dict[str, Callable[[SignalSet, np.ndarray | None], Signature]] = {
    "friction": detect_friction,
    "hysteresis": detect_hysteresis,
    "progressive": detect_progressive,
    "spring": detect_spring,
    "end_stop": detect_end_stop,
    "damper_asymmetry": detect_damper_asymmetry,
    "digressive": detect_digressive,
    "viscoelastic": detect_viscoelastic,
    "sensor_offset": detect_sensor_offset,
    "sensor_gain": detect_sensor_gain,
    "sensor_lag": detect_sensor_lag,
}
#: detector names, in the order they are reported
SIGNATURE_KINDS = tuple(DETECTORS)


def score_signatures(s: SignalSet, kinds: Sequence[str] = SIGNATURE_KINDS) -> list[Signature]:
    """Run the detectors named in ``kinds``; strongest score first."""
    basis = orthonormal_basis(s.jacobian)
    out = [DETECTORS[k](s, basis) for k in kinds]
    return sorted(out, key=lambda g: -g.score)
