"""``diagnose_knc``: locate, name and model what the symmetric, linear axle model leaves
out of K&C rig recordings.

Steps (the engine's, with the K&C pieces where a loop of a two-sided axle needs them):

1. **Split**: fit on some rig tests (default parallel + opposite travel), hold out
   the others (default single-wheel travel) or separate recordings (e.g. another
   amplitude).
2. **Baseline**: fit the plain model's small parameter subset
   (:data:`~suspenv.diagnosis.knc.model.FIT_PARAMETERS`) weighted by the measured
   spread, then again weighted by each channel's residual (its noise scale); these
   scales stay fixed for every model compared.
3. **Locate**: residual map test x channel x branch x side
   (:mod:`~suspenv.diagnosis.knc.locate`).
4. **Signatures**: score tests of the residual against each effect's pattern
   (:mod:`~suspenv.diagnosis.knc.signatures`, about N(0, 1) under noise) and, for the
   elastic and sensor elements, against the model itself
   (:mod:`~suspenv.diagnosis.knc.score_test`: what the fitted parameters cannot
   mimic); each family keeps its stronger score. The first round refits every
   candidate family (``refit_all_first``): a weak effect can stay under the screen's
   threshold in its signature pattern (a top-mount Dahl element opens a wheel-load loop
   of a few newtons) while the refit of the element itself, which has the exact shape,
   is the stronger test. Later rounds refit the families above
   ``screen_threshold``, at most ``screen_families``; when none is, the search stops.
5. **Refit**: the candidate effect is added to the model as a physical element and
   the model refitted (path-dependent elements, slow to simulate: their own parameters
   with the base parameters held; the others: all parameters jointly); evidence and
   decision are the engine's (:func:`suspenv.diagnosis.evidence.compare`,
   :func:`suspenv.diagnosis.name.decide`, :func:`~suspenv.diagnosis.name.rank`):
   corrected likelihood-ratio test with a Bonferroni level, BIC, and held-out error
   reduction.
6. The winner is polished (all parameters jointly, restarted until converged, under
   channel scales reset to its own residual levels: :func:`settle`) and becomes the model of the
   next round (at most ``max_effects``); the final model is compared with the
   baseline on the held-out data. When nothing is named, the verdict states the
   smallest hysteresis (per location) and strut friction these tests would have
   shown (:mod:`~suspenv.diagnosis.knc.detectability`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.engine import Findings
from suspenv.diagnosis.evidence import (
    baseline_summary,
    compare,
)
from suspenv.diagnosis.fit import FitResult, residuals
from suspenv.diagnosis.knc.detectability import detection_limits, limits_sentence
from suspenv.diagnosis.knc.fit import evaluate, fit, noise_scales
from suspenv.diagnosis.knc.locate import residual_map
from suspenv.diagnosis.knc.model import KncAxleModel, KncEffect, base_kind, make_candidate
from suspenv.diagnosis.knc.recording import rig_test
from suspenv.diagnosis.knc.score_test import SCORE_TESTED, score_signatures_by_model
from suspenv.diagnosis.knc.signatures import FAMILY_KINDS, KncSignature, score_signatures
from suspenv.diagnosis.name import (
    Ambiguity,
    Hypothesis,
    ambiguities,
    corrected_delta_bic,
    decide,
    rank,
)

#: effects whose response depends on the travel history (slow to simulate): refitted
#: with the base parameters held, then polished jointly only when named
PATH_DEPENDENT = ("dahl_hysteresis", "coulomb_friction")
#: stopping tolerances (relative change of cost and parameters) of fits of models with
#: and without path-dependent elements; a relative cost change of 1e-4 moves the
#: log-likelihood by about n * 1e-4 / 2 (well below one unit for K&C data sets)
COARSE_TOL = 1e-4
FINE_TOL = 1e-7


def current_slow(model: KncAxleModel) -> bool:
    """True when ``model`` holds a path-dependent (slow to simulate) element."""
    return any(e.kind in PATH_DEPENDENT for e in model.effects)


#: effect kind -> signature family
FAMILY_OF = {k: fam for fam, kinds in FAMILY_KINDS.items() for k in kinds}


@dataclass
class KncDiagnosis(Findings):
    """What the K&C diagnosis found (:class:`~suspenv.diagnosis.engine.Findings` plus the
    recordings fitted and held out)."""

    fit_recordings: list[Any] = field(repr=False, default_factory=list)
    heldout_recordings: list[Any] = field(repr=False, default_factory=list)
    #: when nothing is named: the smallest magnitude of each path-dependent candidate
    #: the fitted tests would show (:func:`~suspenv.diagnosis.knc.detectability.detection_limits`)
    detection_limits: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out["detection_limits"] = self.detection_limits
        return out

    def effect(self, kind: str) -> KncEffect | None:
        """The fitted effect of ``kind`` in the final model (None if not named)."""
        _, effects = self.final_fit.model.unpack(self.final_fit.theta)
        for e in effects:
            if e.kind == kind:
                return e.with_params({k: float(np.ravel(v)[0]) for k, v in e.params.items()})
        return None


def _as_recordings(recordings: Any) -> list[Any]:
    if isinstance(recordings, Mapping):
        return list(recordings.values())
    if isinstance(recordings, list | tuple):
        return list(recordings)
    return [recordings]


def split_tests(recordings: Any, holdout: Any) -> tuple[list[Any], list[Any], str]:
    """(fit, held-out, description): ``holdout`` is rig test name(s) among the
    recordings (e.g. ``"single"``) or separate recordings (e.g. another amplitude)."""
    recs = _as_recordings(recordings)
    if isinstance(holdout, str) or (
        isinstance(holdout, list | tuple) and holdout and all(isinstance(h, str) for h in holdout)
    ):
        names = {holdout} if isinstance(holdout, str) else set(holdout)
        held = [r for r in recs if rig_test(r) in names]
        fitr = [r for r in recs if rig_test(r) not in names]
        if not held or not fitr:
            raise ValidationError(
                f"holdout {sorted(names)} must name some but not all of the recorded tests "
                f"{[rig_test(r) for r in recs]}"
            )
        return fitr, held, f"rig test(s) {', '.join(sorted(names))}"
    held = _as_recordings(holdout)
    return recs, held, "separate recording(s): " + ", ".join(r.name for r in held)


def _start_values(kind: str, sig: KncSignature | None) -> dict[str, float]:
    """Start of a new element's parameters read off its signature."""
    if base_kind(kind) in ("dahl_hysteresis", "coulomb_friction") and sig is not None:
        w = abs(sig.numbers.get("tyre_fz_loop_width_n", 0.0))
        return {"f_c": float(np.clip(0.5 * w, 5.0, 500.0))}
    return {}


def _compose(current: FitResult, ext_model: KncAxleModel, effect_theta: np.ndarray) -> np.ndarray:
    """Full ``theta`` of ``ext_model`` from the current base values and fitted effects."""
    n_base = len(ext_model.base_names)
    return np.concatenate([current.theta[:n_base], effect_theta])


def refit_frozen(
    current: FitResult,
    kind: str,
    recs: Sequence[Any],
    start: Mapping[str, float] | None = None,
    max_nfev: int = 30,
) -> FitResult:
    """Add an effect of ``kind`` to ``current.model`` and refit. Path-dependent effects:
    the effects' parameters only, base parameters held at their current values (the
    full model is polished once the effect is named); others: all parameters jointly.
    Returns the full model's fit."""
    model: KncAxleModel = current.model
    base = dict(zip(model.base_names, current.theta[: len(model.base_names)], strict=True))
    _, effs = model.unpack(current.theta)
    effs = [e.with_params({k: float(np.ravel(v)[0]) for k, v in e.params.items()}) for e in effs]
    new = make_candidate(kind).with_params(dict(start or {}))
    full = model.released().with_effects([*effs, new])
    t0 = time.perf_counter()
    if new.kind not in PATH_DEPENDENT:
        # elastic and sensor effects are cheap to simulate: refit everything jointly
        # two starts: the current fit, and the start design (the current base values may
        # have bent to mimic the missing effect); the better fit is kept
        guess = full.initial_guess()
        starts = [np.concatenate([current.theta, guess[current.theta.size :]])]
        slow = current_slow(full)
        if not slow:
            starts.append(guess)
        best = None
        for theta0 in starts:
            res = fit(
                full,
                recs,
                scales=current.scales,
                theta0=theta0,
                max_nfev=max_nfev,
                tol=COARSE_TOL if slow else FINE_TOL,
            )
            if best is None or res.log_likelihood() > best.log_likelihood():
                best = res
        best.extra["effect"] = new.to_dict()
        return best
    frozen = full.frozen_at(base)
    part = fit(frozen, recs, scales=current.scales, max_nfev=max_nfev, tol=COARSE_TOL)
    theta = _compose(current, full, part.theta)
    res = evaluate(full, theta, recs, current.scales, seconds=time.perf_counter() - t0)
    # uncertainties: base from the current fit, effects from the frozen refit
    n_new = part.theta.size
    res.stderr = np.concatenate([current.stderr[: len(base)], part.stderr[-n_new:]])
    res.stderr_corrected = np.concatenate(
        [current.stderr_corrected[: len(base)], part.stderr_corrected[-n_new:]]
    )
    res.nfev = part.nfev
    res.extra["effect"] = new.to_dict()
    return res


def _hypothesis(
    kind: str,
    rnd: int,
    sig: KncSignature | None,
    current: FitResult,
    ext: FitResult,
    fit_recs: list[Any],
    held: list[Any],
) -> Hypothesis:
    comp = compare(current, ext, fit_recs, None, held, None)
    prefix = ext.extra["effect"]["name"] + "."
    new = make_candidate(kind)
    return Hypothesis(
        kind=new.kind,
        family=FAMILY_OF[new.kind],
        words=new.words,
        round=rnd,
        signature_score=float(sig.score) if sig else float("nan"),
        signature_evidence=sig.evidence if sig else "",
        lr_statistic=comp.lr.statistic,
        lr_statistic_corrected=comp.lr.statistic_corrected,
        lr_dof=comp.lr.dof,
        p_value_corrected=comp.lr.p_value_corrected,
        delta_bic_corrected=corrected_delta_bic(
            comp.lr.statistic_corrected, comp.lr.dof, current.n_samples
        ),
        heldout_reduction=comp.heldout_reduction,
        params={k: v for k, v in ext.params().items() if k.startswith(prefix)},
        fit=ext,
        comparison=comp,
    )


def polish(
    start: FitResult,
    recs: Sequence[Any],
    max_nfev: int,
    tol: float,
    scales: Mapping[str, float] | None = None,
    restarts: int = 3,
) -> FitResult:
    """All parameters of ``start.model`` refitted jointly from ``start.theta`` under
    ``scales`` (default ``start.scales``), the fit restarted from its own result until
    a restart gains less than half a unit of log-likelihood (at most ``restarts`` fits).
    """
    scales = dict(start.scales if scales is None else scales)
    best = fit(start.model, recs, scales=scales, theta0=start.theta, max_nfev=max_nfev, tol=tol)
    for _ in range(restarts - 1):
        again = fit(start.model, recs, scales=scales, theta0=best.theta, max_nfev=max_nfev, tol=tol)
        gain = again.log_likelihood() - best.log_likelihood()
        if gain > 0:
            best = again
        if gain < 0.5:
            break
    return best


def settle(
    start: FitResult, recs: Sequence[Any], max_nfev: int, tol: float, rounds: int = 3
) -> FitResult:
    """The named winner made ready to be the next round's null model.

    Every candidate of the next round is one more fit from this model under its
    channel scales, and the likelihood ratio compares the profile likelihoods (each
    channel's noise at its own estimate). Two things would let a candidate win what
    the null merely missed: a null stopped short of convergence (so the fit is
    restarted until a restart gains under half a unit), and weights that no longer
    match the residual (a channel the named element now explains, e.g. the wheel load
    after strut friction, keeps the large scale of the baseline's misfit and is then
    ignored by the fit but counted by the likelihood). So the scales are set to the
    fit's own residual levels and the fit repeated until they change by less than
    25 % (at most ``rounds`` times). On dev seed 113 (strut friction) a load-cell offset
    of 0.6 N had a likelihood ratio of 141 against a null without these steps.
    """
    best = polish(start, recs, max_nfev, tol)
    for _ in range(rounds):
        new = noise_scales(best)
        change = max(abs(np.log(new[c] / best.scales[c])) for c in new)
        if change < np.log(1.25):
            break
        best = polish(best, recs, max_nfev, tol, scales=new)
    return best


def _candidate(h: Hypothesis) -> str:
    """The candidate name (kind or location variant) a hypothesis was fitted as."""
    return str(h.fit.extra["effect"]["name"]) if h.fit is not None else h.kind


def location_ambiguities(
    win: Hypothesis, ranked: Sequence[Hypothesis], tie_tolerance: float = 0.05
) -> list[Ambiguity]:
    """Other locations of the winner's kind that the data cannot tell apart from it
    (significant, corrected LR statistics within ``tie_tolerance`` or 10)."""
    out = []
    for h in ranked:
        if h is win or h.kind != win.kind or not h.significant:
            continue
        gap = abs(win.lr_statistic_corrected - h.lr_statistic_corrected)
        if gap <= max(tie_tolerance * win.lr_statistic_corrected, 10.0):
            out.append(
                Ambiguity(
                    _candidate(win),
                    _candidate(h),
                    win.words,
                    h.words,
                    "a K&C test that loads the candidate locations differently (lateral or "
                    "longitudinal force at the contact patch, or a top-mount load test)",
                    "in vertical travel the top mount sits in series with the spring, so its "
                    "hysteresis barely changes the wheel load",
                )
            )
    return out


def _signals(fit_: FitResult, recs: Sequence[Any]):
    res = residuals(fit_.model, fit_.theta, recs, fit_.channels)
    pred = [fit_.model.simulate(fit_.theta, r) for r in recs]
    return res, pred


def diagnose_knc(
    recordings: Any,
    holdout: Any = "single",
    model: KncAxleModel | None = None,
    candidates: Sequence[str] | None = None,
    max_effects: int = 2,
    screen_families: int = 5,
    screen_threshold: float = 3.0,
    refit_all_first: bool = True,
    alpha: float = 0.01,
    min_heldout_gain: float = 0.01,
    heldout_rule: str = "noise",
    max_nfev: int = 40,
    polish_nfev: int | None = None,
    report_dir: str | Path | None = None,
    progress: bool = False,
) -> KncDiagnosis:
    """Diagnose K&C rig recordings of the McPherson axle.

    Args:
        recordings: K&C recordings (dict test -> Recording, or a list).
        holdout: rig test name(s) held out (default ``"single"``) or separate recordings.
        model: the base model (default: the plain symmetric :class:`KncAxleModel`).
        candidates: effect kinds considered (default: the model's ``candidate_effects``).
        max_effects: most effects added in turn.
        screen_families / screen_threshold: refit the signature families scoring above
            the threshold (at most this many; the default, 5, is every family: the model
            score tests of the elastic and sensor elements also respond to other missing
            physics, so a cap could crowd out the loop family).
        refit_all_first: the first round refits every candidate family, whatever its
            signature score (the screen then applies from the second round).
        alpha, min_heldout_gain, heldout_rule: the engine's decision rule
            (:func:`suspenv.diagnosis.name.decide`). The held-out rig test sees a
            refit's change only where that test moves the bushings the change is about
            (a progressive rate or a top-mount loop may hardly move single-wheel travel
            predictions), so the default judges the held-out gain in noise units
            (``"noise"``): it vetoes a refit the held-out test refutes and does not veto
            one it cannot see; ``"fraction"`` asks a ``min_heldout_gain`` drop of the
            held-out RMS error whatever its size relative to the noise.
        max_nfev / polish_nfev: budgets of the fits and of each fit of the joint
            polish of a winner (default ``max_nfev``; see :func:`settle`).
        report_dir: when given, the report is written there.
        progress: print one line per step.
    """
    t0 = time.perf_counter()
    fit_recs, held, hold_words = split_tests(recordings, holdout)
    tests = tuple(dict.fromkeys(rig_test(r) for r in fit_recs))
    base_model = model or KncAxleModel(tests=tests)
    cands = list(candidates if candidates is not None else base_model.candidate_effects)
    unknown = [k for k in cands if base_kind(k) not in FAMILY_OF]
    if unknown:
        raise ValidationError(f"candidates must be among {sorted(FAMILY_OF)}, but got {unknown}")

    def say(msg: str) -> None:
        if progress:
            print(f"[{time.perf_counter() - t0:6.1f} s] {msg}", flush=True)

    first = fit(base_model, fit_recs, max_nfev=max_nfev, tol=COARSE_TOL)
    scales = noise_scales(first)
    base = fit(
        base_model, fit_recs, scales=scales, theta0=first.theta, max_nfev=max_nfev, tol=FINE_TOL
    )
    # the scales become the noise-weighted fit's own residual level; the baseline is
    # refitted under them (from its fit and from the start design, as every candidate
    # is), so that no candidate gains likelihood from the change of weights alone
    scales = noise_scales(base)
    nfev = first.nfev + base.nfev
    starts = [base.theta, base_model.initial_guess(fit_recs[0])]
    base = None
    for theta0 in starts:
        trial = fit(
            base_model, fit_recs, scales=scales, theta0=theta0, max_nfev=max_nfev, tol=FINE_TOL
        )
        nfev += trial.nfev
        if base is None or trial.log_likelihood() > base.log_likelihood():
            base = trial
    base.nfev = nfev
    say(f"baseline fitted ({base.nfev} evaluations)")
    res, _ = _signals(base, fit_recs)
    location = residual_map(fit_recs, res, scales)

    current = base
    all_hyps: list[Hypothesis] = []
    named: list[Hypothesis] = []
    amb: list[Ambiguity] = []
    first_sigs: list[KncSignature] = []
    for rnd in range(1, max_effects + 1):
        res, pred = _signals(current, fit_recs)
        done = {h.kind for h in named}
        fams_c = {FAMILY_OF[base_kind(k)] for k in cands}
        noise = residual_map(fit_recs, res, scales).noise  # independent of the fit's scale
        sigs = [s for s in score_signatures(fit_recs, res, pred, noise) if s.kind in fams_c]
        # score tests against the model: effects the fitted parameters partly mimic
        tested = [c for c in cands if c in SCORE_TESTED and c not in done]
        strongest: dict[str, KncSignature] = {}
        for sg in sigs + score_signatures_by_model(current, fit_recs, tested):
            if sg.kind not in strongest or sg.score > strongest[sg.kind].score:
                strongest[sg.kind] = sg
        sigs = sorted(strongest.values(), key=lambda sg: -sg.score)
        if rnd == 1:
            first_sigs = sigs
        open_sigs = [s for s in sigs if any(k not in done for k in FAMILY_KINDS[s.kind])]
        if rnd == 1 and refit_all_first:
            chosen = open_sigs
        else:
            chosen = [s for s in open_sigs if s.score > screen_threshold][:screen_families]
        if not chosen:
            break
        hyps = []
        for sig in chosen:
            kinds = [c for c in cands if FAMILY_OF[base_kind(c)] == sig.kind]
            for kind in (c for c in kinds if base_kind(c) not in done):
                ext = refit_frozen(current, kind, fit_recs, _start_values(kind, sig), max_nfev)
                hyps.append(_hypothesis(kind, rnd, sig, current, ext, fit_recs, held))
                say(
                    f"round {rnd}: {kind} LR {hyps[-1].lr_statistic_corrected:.1f}, "
                    f"held-out {100 * hyps[-1].heldout_reduction:+.1f} %"
                )
        decide(hyps, len(hyps), alpha, min_heldout_gain, heldout_rule=heldout_rule)
        ranked = rank(hyps)
        all_hyps += ranked
        amb += ambiguities(ranked)
        if not ranked or not ranked[0].significant:
            break
        win = ranked[0]
        amb += location_ambiguities(win, ranked)
        polished = settle(
            win.fit,
            fit_recs,
            max_nfev if polish_nfev is None else polish_nfev,
            COARSE_TOL if current_slow(win.fit.model) else FINE_TOL,
        )
        if polished.log_likelihood() >= win.fit.log_likelihood():
            polished.extra["effect"] = win.fit.extra["effect"]
            win.fit = polished
            prefix = win.fit.extra["effect"]["name"] + "."
            win.params = {k: v for k, v in polished.params().items() if k.startswith(prefix)}
        named.append(win)
        current = win.fit
        say(f"round {rnd}: named {win.words}")

    comparison = None
    limits: dict[str, dict[str, float]] = {}
    if named:
        comparison = compare(base, current, fit_recs, None, held, None)
    else:  # say what these tests could not have seen
        limits = detection_limits(base, fit_recs, noise=location.noise)
        say("detection limits computed")
    verdict = _verdict(named, all_hyps, amb, first_sigs, screen_threshold)
    if limits:
        verdict += "; " + limits_sentence(limits)
    baseline = baseline_summary(base, fit_recs, held)
    baseline["scales"] = dict(scales)
    baseline["fit_parameters"] = list(base_model.fit_parameters)
    strongest = location.strongest(1)
    diag = KncDiagnosis(
        recording=", ".join(r.name for r in fit_recs),
        family=base_model.family,
        holdout=hold_words,
        channel=f"{strongest[0][0][1]}" if strongest else "",
        baseline=baseline,
        location=location,
        signatures=first_sigs,
        hypotheses=all_hyps,
        named=named,
        ambiguities=amb,
        verdict=verdict,
        comparison=comparison,
        final_params=current.params(),
        seconds=time.perf_counter() - t0,
        base_fit=base,
        final_fit=current,
        fit_recordings=fit_recs,
        heldout_recordings=held,
        detection_limits=limits,
    )
    if report_dir is not None:
        from suspenv.diagnosis.knc.report import write_knc_report

        write_knc_report(diag, report_dir)
    return diag


def _verdict(
    named: list[Hypothesis],
    hyps: list[Hypothesis],
    amb: list[Ambiguity],
    sigs: list[KncSignature],
    threshold: float,
) -> str:
    if not named:
        best = min(hyps, key=lambda h: h.p_value_corrected, default=None)
        tail = ""
        if best is None and sigs:
            tail = (
                f" (no residual signature above {threshold:g}; strongest: {sigs[0].kind} "
                f"{sigs[0].score:.1f})"
            )
        if best is not None:
            tail = (
                f" (strongest candidate, {best.words}: corrected p = {best.p_value_corrected:.2g}, "
                f"held-out error change {-100 * best.heldout_reduction:+.1f} %"
                f"{_z_words(best)})"
            )
        return "no significant missing physics" + tail
    text = "missing physics: " + "; then ".join(h.words for h in named)
    if amb:
        text += ". " + " ".join(a.sentence() for a in amb)
    return text


def _z_words(h: Hypothesis) -> str:
    """ ", held-out z = ..." when the hypothesis carries its comparison."""
    if h.comparison is None or not np.isfinite(h.comparison.heldout_z):
        return ""
    return f", held-out z = {h.comparison.heldout_z:+.1f}"
