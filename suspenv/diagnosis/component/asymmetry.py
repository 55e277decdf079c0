"""Damper bump/rebound asymmetry, tested against a constant force (gas force / offset).

A check the component family runs after its search, where a digressive damper curve is
named and bump/rebound asymmetry is a candidate not yet named
(:func:`asymmetry_check`): the asymmetric curve against the symmetric one plus a
constant force, with a block cross-validation over interleaved cycles and the
model-free matched-speed test (:mod:`suspenv.diagnosis.component.matched_speed`).

Units: forces [N], velocities [m/s].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.diagnosis.component.matched_speed import MatchedSpeedAsymmetry, matched_speed_asymmetry
from suspenv.diagnosis.component.motion import cycle_index, motion
from suspenv.diagnosis.component.refit import refit_with
from suspenv.diagnosis.evidence import Comparison, compare, heldout_residuals, relative_drop
from suspenv.diagnosis.fitting import FitResult, fit
from suspenv.diagnosis.hypothesis import Hypothesis, corrected_delta_bic
from suspenv.diagnosis.split import Split
from suspenv.models.effects import make_effect


@dataclass
class AsymmetryCheck:
    """Bump/rebound asymmetry of a damper curve, tested against a constant force.

    ``ratio`` is the rebound force over the bump force of the velocity-dependent
    curve (linear base plus digressive element) at ``v_ref`` [m/s], minus one
    (positive: rebound stronger); ``ratio_stderr`` its standard error from the
    parameter covariance inflated for serially correlated residuals (AR(1)
    effective sample size); with an interleaved-cycle split, ``fold_ratios`` and
    ``fold_heldout_reductions`` repeat the comparison with each group of cycles held
    out in turn (block cross-validation, robust to serial correlation) and
    ``ratio_stderr_folds`` is their jackknife standard error (the null and alternative
    models: :func:`asymmetry_check`). ``matched_speed`` is the model-free check on cyclic
    strokes (:mod:`suspenv.diagnosis.component.matched_speed`).
    """

    v_ref: float
    ratio: float
    ratio_stderr: float
    offset: float
    heldout_reduction: float
    lr_statistic_corrected: float
    p_value_corrected: float
    delta_bic_corrected: float
    supported: bool
    sentence: str
    params: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_ratios: list[float] = field(default_factory=list)
    fold_heldout_reductions: list[float] = field(default_factory=list)
    ratio_stderr_folds: float = float("nan")
    matched_speed: MatchedSpeedAsymmetry | None = None
    hypothesis: Hypothesis | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        out = {k: v for k, v in self.__dict__.items() if k not in ("hypothesis", "matched_speed")}
        out["matched_speed"] = self.matched_speed.to_dict() if self.matched_speed else None
        return out


def _curve_force(result: FitResult, v: float) -> float:
    """Velocity-dependent damper force [N] at velocity ``v``: linear base plus the
    (a)symmetric digressive element of ``result`` (hysteresis, lag and offset left out)."""
    p = dict(zip(result.names, result.theta, strict=True))
    f = float(p.get("c", 0.0)) * v
    for e in result.model.effects:
        if e.kind in ("digressive_damping", "asymmetric_digressive_damping"):
            own = {k.split(".", 1)[1]: val for k, val in p.items() if k.startswith(e.name + ".")}
            f += float(e.with_params(own).force(np.zeros(1), np.array([v]))[0])
    return f


def _rebound_bump_ratio(result: FitResult, v_ref: float) -> tuple[float, float]:
    """Rebound over bump force of the curve at ``v_ref``, minus one, and its standard
    error (delta method; covariance inflated like ``stderr_corrected``)."""

    def ratio(theta: np.ndarray) -> float:
        trial = FitResult(**{**result.__dict__, "theta": theta})
        return -_curve_force(trial, -v_ref) / _curve_force(trial, v_ref) - 1.0

    r0 = ratio(result.theta)
    grad = np.zeros(result.theta.size)
    for i in range(result.theta.size):
        h = 1e-6 * max(abs(result.theta[i]), 1.0)
        th = result.theta.copy()
        th[i] += h
        grad[i] = (ratio(th) - r0) / h
    cov = result.covariance_corrected()
    return r0, float(np.sqrt(max(grad @ cov @ grad, 0.0)))


def asymmetry_check(
    current: FitResult,
    sp: Split,
    alpha: float = 0.01,
    min_heldout_gain: float = 0.01,
    max_nfev: int = 200,
) -> AsymmetryCheck | None:
    """Is the damper curve of ``current`` asymmetric between bump and rebound?

    Needs a ``digressive_damping`` element in ``current.model`` (else None). Null model:
    :func:`_with_constant_force`; alternative: :func:`_asymmetric_refit`. The asymmetry
    is *supported* when the likelihood-ratio test corrected for serial correlation passes
    (p < ``alpha``), the corrected BIC falls, the held-out error falls by at least
    ``min_heldout_gain``, and the ratio differs from zero by more than two standard
    errors; or when the model-free matched-speed check rejects a constant force and a
    drifting zero and the asymmetric refit lowers the held-out error.
    """
    if not (dig := [e for e in current.model.effects if e.kind == "digressive_damping"]):
        return None
    base_offset = "f_0" in current.names  # a base model with its own constant force
    null = _with_constant_force(current, sp, base_offset, max_nfev)
    asym, alt = _asymmetric_refit(null, dig[0], sp, max_nfev)
    comp = compare(null, alt, sp)
    v_all = np.concatenate([np.abs(motion(r)[1]) for r in sp.fit_recordings])
    v_ref = float(np.percentile(v_all, 99))
    ratio, se = _rebound_bump_ratio(alt, v_ref)
    dbic = corrected_delta_bic(comp.lr.statistic_corrected, comp.lr.dof, null.n_samples)
    fold_r, fold_h = _cycle_folds(null, alt, sp, v_ref, max_nfev)
    se_folds = _jackknife_stderr(fold_r)
    se_all = float(np.nanmax([se, se_folds]))
    folds_agree = not fold_h or float(np.mean(fold_h)) >= min_heldout_gain
    supported = bool(
        comp.lr.p_value_corrected < alpha
        and dbic < 0.0
        and comp.heldout_reduction >= min_heldout_gain
        and folds_agree
        and abs(ratio) > 2.0 * se_all
    )
    matched = _matched_speed(sp, alpha)
    if matched is not None and matched.supported and comp.heldout_reduction > 0.0:
        supported = True
    offset = _constant_force(null, alt, base_offset)
    numbers = _numbers(ratio, se_all, v_ref, offset, comp, fold_h, dbic)
    words = make_effect(asym.kind, location=asym.location).words
    hyp = Hypothesis.from_comparison(
        asym.kind, "", words, 0, null, alt, comp, signature_evidence=numbers
    )
    hyp.significant = supported
    return AsymmetryCheck(
        v_ref=v_ref,
        ratio=float(ratio),
        ratio_stderr=float(se),
        offset=offset,
        heldout_reduction=float(comp.heldout_reduction),
        lr_statistic_corrected=float(comp.lr.statistic_corrected),
        p_value_corrected=float(comp.lr.p_value_corrected),
        delta_bic_corrected=float(dbic),
        supported=supported,
        sentence=_sentence(numbers, supported, matched),
        params=hyp.params,
        fold_ratios=fold_r,
        fold_heldout_reductions=fold_h,
        ratio_stderr_folds=se_folds,
        matched_speed=matched,
        hypothesis=hyp,
    )


def _with_constant_force(
    current: FitResult, sp: Split, base_offset: bool, max_nfev: int
) -> FitResult:
    """The null model: ``current`` with a constant force (``force_offset``) refitted,
    unless it has one (its base model's ``f_0`` where ``base_offset``, or a force offset
    or gas spring element)."""
    has_one = any(e.kind in ("force_offset", "gas_spring") for e in current.model.effects)
    if base_offset or has_one:
        return current
    return refit_with(current, "force_offset", sp.fit_recordings, sp.fit_masks, max_nfev=max_nfev)


def _asymmetric_refit(null: FitResult, dig: Any, sp: Split, max_nfev: int) -> tuple[Any, FitResult]:
    """The alternative model: ``null`` with its digressive element ``dig`` replaced by an
    ``asymmetric_digressive_damping`` whose bump and rebound branches start at the
    symmetric values, refitted; returns the new element and the fit."""
    vals = dict(zip(null.names, null.theta, strict=True))
    c_low, v_knee = vals[f"{dig.name}.c_low"], vals[f"{dig.name}.v_knee"]
    asym = make_effect(
        "asymmetric_digressive_damping",
        location=dig.location,
        c_bump=c_low,
        v_knee_bump=v_knee,
        c_rebound=c_low,
        v_knee_rebound=v_knee,
    )
    alt_effects = tuple(asym if e.name == dig.name else e for e in null.model.effects)
    alt_model = null.model.with_effects(alt_effects)
    theta0 = {k: v for k, v in vals.items() if not k.startswith(dig.name + ".")}
    theta0.update({f"{asym.name}.{k}": float(v) for k, v in asym.params.items()})
    alt = fit(alt_model, sp.fit_recordings, sp.fit_masks, theta0=theta0, max_nfev=max_nfev)
    alt.extra["effect"] = asym.to_dict()
    return asym, alt


def _jackknife_stderr(values: list[float]) -> float:
    """The jackknife standard error of the fold estimates ``values`` (NaN for fewer
    than two)."""
    if len(values) <= 1:
        return float("nan")
    k = len(values)
    return float(np.sqrt((k - 1) / k * np.sum((np.array(values) - np.mean(values)) ** 2)))


def _constant_force(null: FitResult, alt: FitResult, base_offset: bool) -> float:
    """The constant force [N] (force offset, gas force or the base model's ``f_0``) of
    the alternative fit ``alt`` (NaN where it has none)."""
    off_name = next(
        (e.name for e in null.model.effects if e.kind in ("force_offset", "gas_spring")),
        "",
    )
    off_keys = (f"{off_name}.offset", f"{off_name}.f_0") + (("f_0",) if base_offset else ())
    off_key = next((k for k in off_keys if k in alt.names), None)
    return float(alt.theta[alt.names.index(off_key)]) if off_key else float("nan")


def _numbers(
    ratio: float,
    stderr: float,
    v_ref: float,
    offset: float,
    comp: Comparison,
    fold_h: list[float],
    dbic: float,
) -> str:
    """The check's numbers in words: the ``ratio`` (rebound over bump force at ``v_ref``
    [m/s], minus one) with its standard error, the constant force ``offset`` [N], the
    held-out change (over the cycle folds ``fold_h`` where there are some), the corrected
    p-value and BIC change ``dbic``."""
    side = "rebound" if ratio >= 0 else "bump"
    folds = ""
    if fold_h:
        folds = (
            f", mean held-out change over {len(fold_h)} cycle folds "
            f"{-100 * float(np.mean(fold_h)):+.1f} %"
        )
    return (
        f"bump/rebound asymmetry of {100 * ratio:+.1f} % ± {100 * stderr:.1f} % ({side} "
        f"stronger at {v_ref:.3g} m/s, {abs(ratio) / stderr:.1f} standard errors; constant "
        f"force (gas force / offset) {offset:.3g} N in both models; held-out error change "
        f"{-100 * comp.heldout_reduction:+.1f} %{folds}; corrected p = "
        f"{comp.lr.p_value_corrected:.2g}, corrected BIC change {dbic:+.1f})"
    )


def _sentence(numbers: str, supported: bool, matched: MatchedSpeedAsymmetry | None) -> str:
    """The check's sentence: its ``numbers``, whether the recording supports the
    asymmetry, and the model-free check's sentence where it ran."""
    if supported:
        sentence = f"{numbers}: supported by this recording"
    elif matched is not None:
        sentence = f"{numbers}: not supported by the fitted curve alone"
    else:
        sentence = (
            f"{numbers}: below what this recording can separate from an offset; a test at "
            "higher velocity / a pure sine sweep would separate them (an asymmetry grows "
            "with speed, a gas force or offset does not)"
        )
    return sentence if matched is None else f"{sentence}. Model-free check, {matched.sentence}"


def _matched_speed(sp: Split, alpha: float) -> MatchedSpeedAsymmetry | None:
    """The model-free matched-speed test (:mod:`suspenv.diagnosis.component.matched_speed`) on
    the first fitted recording with a force channel and enough matched speeds."""
    for rec in sp.fit_recordings:
        if (force := rec.outputs.get("force")) is None:
            continue
        x, v = motion(rec)
        if (out := matched_speed_asymmetry(rec.time, v, force, x, alpha=alpha)) is not None:
            return out
    return None


def _cycle_folds(
    null: FitResult, alt: FitResult, sp: Split, v_ref: float, max_nfev: int
) -> tuple[list[float], list[float]]:
    """Block cross-validation over interleaved cycles (only for a ``"cycles"`` split):
    for each group ``g`` of cycles (cycle index mod N == g) refit both models on the
    other cycles, and return the asymmetry ratio of each refit and the relative
    reduction of the held-out RMS error on group ``g`` (same scaling as ``compare``)."""
    every = sp.cycles_every
    if not every or sp.fit_masks is None:
        return [], []
    recs = sp.fit_recordings
    cycs = [cycle_index(motion(r)[0]) for r in recs]
    ratios, gains = [], []
    for g in range(every):
        hold = [(c % every) == g for c in cycs]
        fit_m = [~m for m in hold]
        n0 = fit(null.model, recs, fit_m, theta0=null.theta, max_nfev=max_nfev)
        n1 = fit(alt.model, recs, fit_m, theta0=alt.theta, max_nfev=max_nfev)
        before, after = heldout_residuals(n0, recs, hold), heldout_residuals(n1, recs, hold)
        ratios.append(_rebound_bump_ratio(n1, v_ref)[0])
        gains.append(relative_drop(before, after, n0.scales))
    return ratios, gains
