"""How visible an effect is in K&C rig data: signal-to-noise of what the plain model
cannot absorb.

Two views of the same quantity, the noncentrality ``lambda = sum((d / sigma)^2)`` of
the part ``d`` of an effect's signature that the plain symmetric model's fitted
parameters cannot mimic (summed over the samples of every channel of the fitted rig
tests; ``sigma`` each channel's noise). A likelihood-ratio test of the added element
then has an expected statistic of about ``lambda``; this module calls
``snr = sqrt(lambda)`` and an effect *detectable* when ``snr >= DETECTABLE_SNR``.

* the benchmark's ``truth_snr`` (``benchmarks/knc_truth.py``, truth known): the plain
  model is fitted to the *noise-free* loops of the truth vehicle, weighted by the
  case's noise levels; its residual is ``d``.
* :func:`detection_limits` (diagnosis side, truth unknown): a candidate element at a
  reference magnitude is added to the fitted baseline; the change of the prediction,
  with the part the baseline's parameters can follow projected out (the fit's
  Jacobian), is ``d``; the magnitude at which ``snr`` reaches ``DETECTABLE_SNR`` is the
  smallest the data would show (``d`` scales about linearly with the magnitude:
  saturated Dahl loops widen in proportion to their saturation force).

Units: channels in SI (ISO 8855, lateral outboard positive), noise in the channel's
unit; ``lambda`` and ``snr`` are dimensionless.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from suspenv.diagnosis.fitting import stacked_residual
from suspenv.diagnosis.screening import orthonormal_basis
from suspenv.rigs.knc_axle import KncAxleModel, effect_words, make_candidate

#: an effect is called detectable when the unabsorbed signal reaches this many sigma
DETECTABLE_SNR = 5.0
#: candidates whose detection limit a diagnosis states when it names nothing:
#: candidate -> (parameter, reference magnitude in the parameter's unit)
LIMIT_CANDIDATES: dict[str, tuple[str, float]] = {
    "dahl_hysteresis@top_mount": ("f_c", 100.0),
    "dahl_hysteresis@lower_arm": ("f_c", 100.0),
    "coulomb_friction": ("f_c", 100.0),
}


def detection_limits(
    base: Any, recs: Sequence[Any], noise: Mapping[str, float]
) -> dict[str, dict[str, Any]]:
    """Smallest magnitude of each of :data:`LIMIT_CANDIDATES` the fitted recordings would
    show (at :data:`DETECTABLE_SNR`).

    ``base`` is the baseline :class:`~suspenv.diagnosis.fitting.FitResult` (its
    ``extra["jacobian"]`` is the Jacobian of the residual scaled by ``base.scales``).
    ``noise`` (channel unit) is each channel's noise level, an estimate independent of
    the fit (the residual map's roughness noise: the baseline's residual RMS, which an
    unmodelled effect inflates, would not do). Returns
    ``candidate -> {"parameter", "reference", "snr_at_reference", "exponent", "limit"}``
    (``limit`` in the parameter's unit; ``inf`` when the element leaves no trace).
    """
    model: KncAxleModel = base.model
    recs = list(recs)
    channels = list(base.scales)
    noise = {c: float(noise[c]) for c in channels}
    # rows in base-scale units -> rows in noise units
    w = np.concatenate(
        [np.full(r.n_samples, base.scales[c] / noise[c]) for r in recs for c in channels]
    )
    r0 = stacked_residual(model, base.theta, recs, channels, base.scales)
    # the span of the base parameters' Jacobian (rows in noise units): what they can follow
    J = base.extra.get("jacobian")
    Q = orthonormal_basis(None if J is None or J.shape[0] != w.size else J * w[:, None])
    values, current = model.parts(base.theta)

    def snr_at(cand: str, param: str, value: float) -> float:
        eff = make_candidate(cand).with_params({param: value})
        ext = model.with_effects([*current, eff])
        theta = ext.theta_from(values, [*current, eff])
        d = (r0 - stacked_residual(ext, theta, recs, channels, base.scales)) * w
        if Q is not None:
            d = d - Q @ (Q.T @ d)
        return float(np.sqrt(np.sum(d**2)))

    def power_law(p1: tuple[float, float], p2: tuple[float, float]) -> tuple[float, float]:
        """(exponent, magnitude at :data:`DETECTABLE_SNR`) of ``s ~ value^a`` through two
        points."""
        (v1, s1), (v2, s2) = p1, p2
        a = np.log(s2 / s1) / np.log(v2 / v1) if (s1 > 0 and s2 > 0 and v1 != v2) else 1.0
        a = float(np.clip(a, 0.25, 2.0)) if np.isfinite(a) else 1.0
        return a, float(v1 * (DETECTABLE_SNR / s1) ** (1.0 / a))

    out = {}
    for cand, (param, ref) in LIMIT_CANDIDATES.items():
        pts = [(ref, snr_at(cand, param, ref)), (0.5 * ref, snr_at(cand, param, 0.5 * ref))]
        limit, exponent = float("inf"), float("nan")
        if pts[0][1] > 0 and pts[1][1] > 0:
            exponent, limit = power_law(*pts)
            guess = float(np.clip(limit, 0.02 * ref, 50.0 * ref))
            if not 0.4 * ref <= guess <= 1.2 * ref:  # refine once near the limit
                near = min(pts, key=lambda q: abs(np.log(q[0] / guess)))
                third = (guess, snr_at(cand, param, guess))
                if third[1] > 0:
                    exponent, limit = power_law(third, near)
        out[cand] = {
            "parameter": param,
            "reference": float(ref),
            "snr_at_reference": pts[0][1],
            "exponent": exponent,
            "limit": limit,
        }
    return out


def _magnitude(x: float) -> str:
    return f"{x:.0f}" if (x >= 10 or not np.isfinite(x)) else f"{x:.2g}"


def limits_sentence(limits: Mapping[str, Mapping[str, float]]) -> str:
    """The detection limits in words (for the verdict and the report)."""
    parts = [
        f"{effect_words(make_candidate(c))} below {v['parameter']} ~ {_magnitude(v['limit'])} N"
        for c, v in limits.items()
    ]
    parts = [
        p.replace("rubber bushing hysteresis (Dahl) in the ", "hysteresis in the ") for p in parts
    ]
    if not parts:
        return ""
    return (
        f"at this noise level these tests would not show (snr < {DETECTABLE_SNR:g}) "
        + ", ".join(parts)
        + " (in vertical travel the top mount is in series with the spring, so its "
        "hysteresis hardly moves the wheel load; a lateral or longitudinal compliance "
        "test loads it directly)"
    )
