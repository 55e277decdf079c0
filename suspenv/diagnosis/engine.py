"""The diagnosis loop: fit baseline -> locate -> screen -> refit -> decide -> settle -> verdict.

``diagnose(recordings, family, holdout)`` is the one loop every diagnosis runs. The
``family`` (:mod:`suspenv.diagnosis.family`) supplies what depends on the model: a
component on a dyno or rig (:class:`~suspenv.diagnosis.component.family.ComponentFamily`),
the McPherson axle on a K&C rig (:class:`~suspenv.diagnosis.knc.family.KncFamily`), the
minibus on ride tests (:class:`~suspenv.diagnosis.ride.family.RideFamily`), a road
profile's spectrum (:class:`~suspenv.diagnosis.road.RoadFamily`). The loop:

1. **fit** the baseline (the plain model);
2. **locate** where its residual lives;
3. each round: **screen** the open candidates (those of a signature family not yet
   named) against the current residual; **refit** the chosen ones, each as a physical
   element added to the current model, and run the family's refit checks on each
   (:func:`suspenv.diagnosis.checks.refuse`: a refused refit is a failed hypothesis);
   **decide** which are significant
   (:func:`suspenv.diagnosis.decision.decide`, Bonferroni over the candidates screened
   in the round) and rank them; the best significant one is named, **settled** (made
   ready to be the next round's null model) and becomes the current model; the search
   stops when nothing is significant or after ``family.max_effects`` rounds;
4. the **checks** (:mod:`suspenv.diagnosis.checks`, in the order it gives); the final
   model is compared with the baseline on the held-out data and the verdict is worded
   from the findings (:func:`verdict_words`).

The returned :class:`Diagnosis` holds everything and turns into JSON with
:meth:`Diagnosis.to_dict`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.diagnosis import checks
from suspenv.diagnosis.checks.finding import jsonable
from suspenv.diagnosis.decision import DecisionRule, decide, rank
from suspenv.diagnosis.evidence import Comparison, baseline_summary, compare
from suspenv.diagnosis.family import Conclusion, DiagnosisFamily, Outcome, Setup
from suspenv.diagnosis.fitting import FitResult
from suspenv.diagnosis.hypothesis import (
    Ambiguity,
    Hypothesis,
    Withdrawal,
    family_of,
    split_candidate,
)
from suspenv.diagnosis.split import Holdout, Recordings, Split
from suspenv.diagnosis.sufficiency import check_setup
from suspenv.diagnosis.unrecorded import profile, still_switching, switched_left


@dataclass
class Diagnosis:
    """Everything a diagnosis found; ``to_dict()`` is the machine-readable report.

    Attributes:
        recording: names of the fitted recordings.
        family: the diagnosis family (``"component"``, ``"knc"``, ``"ride"``, ``"road"``).
        model: the model family (``"damper"``, ``"knc_axle"``, ``"minibus_ride"``, ...).
        holdout: the held-out data in words.
        channel: the channel where the baseline's residual is largest.
        baseline: the baseline fit's numbers (:func:`~suspenv.diagnosis.evidence.baseline_summary`).
        location: the family's residual map (``to_dict()``).
        signatures: the first round's screening records, strongest first.
        hypotheses: every hypothesis refitted, round by round.
        named: the significant hypotheses, in the order they were added.
        ambiguities: what the data cannot separate, and the test that would.
        verdict: the verdict in words.
        comparison: final model against baseline (None when nothing was named).
        final_params: the final model's parameters with standard errors.
        seconds: wall time.
        rule: the decision rule used.
        findings: the checks after the search by name (``residual_left``,
            ``assumptions``, a family's ``asymmetry``, ``detection_limits``, ...).
        confident: False when the residual left says physics outside the candidate
            list remains.
        evidence: the sentences behind the headline (ambiguities, the family's checks).
    """

    recording: str
    family: str
    model: str
    holdout: str
    channel: str
    baseline: dict[str, Any]
    location: Any
    signatures: list[Any]
    hypotheses: list[Hypothesis]
    named: list[Hypothesis]
    ambiguities: list[Ambiguity]
    verdict: str
    comparison: Comparison | None
    final_params: dict[str, dict[str, float]]
    seconds: float
    rule: DecisionRule
    split: Split = field(repr=False)
    base_fit: FitResult = field(repr=False)
    final_fit: FitResult = field(repr=False)
    findings: dict[str, Any] = field(default_factory=dict)
    confident: bool = True
    evidence: list[str] = field(default_factory=list)

    @property
    def named_kinds(self) -> list[str]:
        """Effect kinds named, in order."""
        return [h.kind for h in self.named]

    @property
    def named_candidates(self) -> list[str]:
        """Candidates named (``kind@location``), in order."""
        return [h.candidate for h in self.named]

    @property
    def named_families(self) -> list[str]:
        return [h.family for h in self.named]

    @property
    def fit_recordings(self) -> list[Any]:
        return self.split.fit_recordings

    @property
    def heldout_recordings(self) -> list[Any]:
        return self.split.heldout_recordings

    @property
    def asymmetry(self) -> Any:
        """The damper bump/rebound check (components; None elsewhere)."""
        return self.findings.get("asymmetry")

    @property
    def residual(self) -> Any:
        """The family's record behind the residual-left check
        (:mod:`suspenv.diagnosis.checks.residual_left`; components: one
        :class:`~suspenv.diagnosis.component.residual_left.ResidualLeft` per output
        channel; ride: :class:`~suspenv.diagnosis.ride.residual.ResidualCheck`; None
        where the family has no noise model)."""
        found = self.findings.get("residual_left")
        return found.record if found is not None else None

    @property
    def headline(self) -> str:
        """The verdict in one short line (the evidence follows in :attr:`verdict` and the
        report): what is missing, whether a residual nobody can name is left, or that the
        model does not describe the recording."""
        if self.findings.get("misfit"):
            return "The model does not describe this recording: no verdict on missing physics"
        named = "; then ".join(h.words for h in self.named)
        if self.unexplained:
            # what a probe outside the library found (a pure time delay), in short
            left = [r for r in self._records() if getattr(r, "remains", False)]
            shapes = "; ".join(r.short() for r in left if hasattr(r, "short"))
            if named:
                return (
                    f"Missing physics (not confident): {named}; a residual above the noise "
                    "remains that the library does not explain" + (f" ({shapes})" if shapes else "")
                )
            return "Unexplained residual above noise, not in the library" + (
                f": {shapes}" if shapes else ""
            )
        if named:
            head = "Missing physics" if self.confident else "Missing physics (not confident)"
            return f"{head}: {named}"
        return "No significant missing physics"

    @property
    def unexplained(self) -> bool:
        """True when a residual above the noise floor is left that no named element
        explains (components and ride)."""
        return any(bool(getattr(r, "remains", False)) for r in self._records())

    def _records(self) -> list[Any]:
        """Every check's record (a finding holds one, or a list of them)."""
        records: list[Any] = []
        for v in self.findings.values():
            records += list(v) if isinstance(v, list) else [v]
        return records

    @property
    def assumptions(self) -> list[str]:
        """The defaults and estimates used for what the recordings do not say
        (:mod:`suspenv.diagnosis.checks.assumptions`)."""
        found = self.findings.get("assumptions")
        return list(found.numbers["assumptions"]) if found is not None else []

    @property
    def detection_limits(self) -> dict[str, dict[str, Any]]:
        """Smallest effects the fitted tests would have shown (K&C, when nothing is named)."""
        return self.findings.get("detection_limits", {})

    def effect(self, kind: str) -> Any:
        """The fitted element of ``kind`` in the final model, its values set as numbers
        (None if absent; :meth:`~suspenv.diagnosis.fitting.FitResult.element`)."""
        if (e := self.final_fit.element(kind)) is None:
            return None
        return e.with_params({k: float(np.ravel(v)[0]) for k, v in e.params.items()})

    def to_dict(self) -> dict[str, Any]:
        plain: tuple[str, ...] = ("recording", "family", "model", "holdout", "channel", "verdict")
        plain += ("confident", "unexplained", "headline", "assumptions", "evidence")
        return {k: getattr(self, k) for k in plain} | {
            "rule": self.rule.to_dict(),
            "named": [
                {k: getattr(h, k) for k in ("kind", "location", "candidate", "family", "words")}
                | {"params": h.params}
                for h in self.named
            ],
            "ambiguities": [a.to_dict() for a in self.ambiguities],
            "baseline": self.baseline,
            "final_params": self.final_params,
            "comparison": self.comparison.to_dict() if self.comparison else None,
            "location": self.location.to_dict(),
            "signatures": [s.to_dict() for s in self.signatures],
            "hypotheses": [h.to_dict() for h in self.hypotheses],
            "findings": {k: jsonable(v) for k, v in self.findings.items()},
            "seconds": self.seconds,
        }


def diagnose(
    recordings: Recordings,
    family: DiagnosisFamily | str,
    holdout: Holdout = None,
    candidates: Sequence[str] | None = None,
    progress: bool = False,
    profiling: bool = True,
) -> Diagnosis:
    """Diagnose what ``family``'s model leaves out of ``recordings``.

    Args:
        recordings: one recording, a list, or a mapping test -> recording.
        family: a :class:`~suspenv.diagnosis.family.DiagnosisFamily`, or a name:
            a component model family (``"damper"``, ``"mr_damper"``,
            ``"friction_guide"``, ``"quarter_car_rig"``, ...), ``"knc"`` or ``"ride"``
            (with the family's defaults; see :func:`make_family`).
        holdout: the held-out data, in the family's terms (default: the family's).
        candidates: candidate names to consider (default: the model's own list).
        progress: print one line per step.
        profiling: profile out an input the recording does not carry where the
            missing-input check finds one, on the baseline's residual or the final
            model's (:mod:`suspenv.diagnosis.unrecorded`, which says when it is kept).

    Raises:
        ValidationError: for data the diagnosis cannot judge, before any fitting (too
            few samples or cycles for the model, non-finite values, units the model does
            not read, implausible magnitudes; :mod:`suspenv.diagnosis.sufficiency`).
    """
    t0 = time.perf_counter()
    fam = make_family(family) if isinstance(family, str) else family
    setup = fam.prepare(recordings, holdout, candidates)
    # refuse data the diagnosis cannot judge before any fitting (values, samples, cycles)
    check_setup(setup, fam)
    run = _Run(fam, setup, progress, t0)
    base = fam.fit_baseline(setup)
    run.say(f"baseline fitted ({base.nfev} evaluations)")
    ctx, channel, unrecorded = _judged(run, base, profile(fam, setup, base) if profiling else None)
    late = switched_left(ctx) if profiling and unrecorded is None else None
    if late is not None and (again := profile(fam, setup, base, late)) is not None:
        # under the check's size beside the baseline's misfit, above it beside the named
        ctx, channel, unrecorded = _judged(run, base, again)
    if unrecorded is not None:
        if not still_switching(ctx):  # what looked switched, an element explains
            return diagnose(recordings, fam, holdout, candidates, progress, profiling=False)
        # the baseline's missing-input finding stands: the fits profiled its input out
        checks.fold(ctx, unrecorded[1])
    return _diagnosis(run, ctx, channel)


def _judged(
    run: _Run, base: FitResult, unrecorded: tuple[FitResult, checks.Finding] | None
) -> tuple[checks.Context, str, tuple[FitResult, checks.Finding] | None]:
    """The search from ``base`` (from its refit beside an unrecorded input, where there is
    one) and the checks on its outcome: (context, the channel located, the input)."""
    if unrecorded is not None:
        base = unrecorded[0]
        run.say(f"baseline refitted beside an unrecorded input ({unrecorded[1].numbers['signal']})")
    location, channel = run.fam.locate(base, run.setup)
    ctx = checks.Context(run.fam, run.setup, _search(run, base, location), run.fam.rule)
    if gone := ctx.outcome.withdrawn:  # kept with the checks' (the family says them)
        checks.fold(ctx, Conclusion(withdrawn=list(gone)))
    checks.run(ctx)
    return ctx, channel, unrecorded


@dataclass
class _Run:
    """One run of :func:`diagnose`: the family, its data and the clock of the progress
    lines (``t0``: :func:`time.perf_counter` at the start [s])."""

    fam: DiagnosisFamily
    setup: Setup
    progress: bool
    t0: float

    def say(self, msg: str) -> None:
        """Print ``msg`` after the seconds since the start (when ``progress``)."""
        if self.progress:
            print(f"[{time.perf_counter() - self.t0:6.1f} s] {msg}", flush=True)

    def versus(self, parent: FitResult, child: FitResult) -> Comparison:
        """``child`` against ``parent``, the held-out gain in noise units (the parent's
        scales) where the rule says so (``heldout_rule = "noise"``: fits weighted by
        noise levels, :func:`~suspenv.diagnosis.fitting.noise_scales`)."""
        noise = dict(parent.scales) if self.fam.rule.heldout_rule == "noise" else None
        return compare(parent, child, self.setup.split, noise)


def _search(run: _Run, base: FitResult, location: Any) -> Outcome:
    """Step 3 of the module docstring: rounds from the baseline ``base`` until one names
    nothing or ``family.max_effects`` rounds have run."""
    state = Outcome(base, base, [], [], [], location)
    for rnd in range(1, run.fam.max_effects + 1):
        if not _round(run, state, rnd):
            break
    return state


def _round(run: _Run, state: Outcome, rnd: int) -> bool:
    """Round ``rnd`` of the search on ``state`` (updated in place): screen the open
    candidates, refit the chosen ones, decide, and name the best significant one (the
    next round's null model). True when an element was named."""
    fam = run.fam
    done = {h.family for h in state.named}
    open_c = [c for c in run.setup.candidates if family_of(split_candidate(c)[0]) not in done]
    if not open_c:
        return False
    screening = fam.screen(state.current, run.setup, open_c, rnd)
    if rnd == 1:
        state.signatures = screening.signatures
    if not screening.chosen:
        return False
    hyps: list[Hypothesis] = []
    for cand, sig in screening.chosen:
        h = _hypothesis(run, state, cand, sig, rnd)
        if h.fit is None:  # a failed refit is recorded at once
            state.hypotheses.append(h)
            continue
        hyps.append(h)
        run.say(
            f"round {rnd}: {cand} LR {h.lr_statistic_corrected:.1f}, "
            f"held-out {100 * h.heldout_reduction:+.1f} %"
        )
    decide(hyps, len(open_c), fam.rule)
    ranked = rank(hyps)
    state.hypotheses += ranked
    if not ranked or not ranked[0].significant:
        return False
    win = ranked[0]
    assert win.fit is not None  # a significant hypothesis carries its refit
    if (settled := fam.settle(win.fit, run.setup)) is not None:
        win.fit = settled
        win.params = win.own_params()
    state.named.append(win)
    state.current = win.fit
    run.say(f"round {rnd}: named {win.words}")
    _retest(run, state)
    return True


def _retest(run: _Run, state: Outcome) -> None:
    """The element named in the round before, judged again beside the one just named
    (stepwise selection's backward step; the family's optional ``without``: its current
    model refitted without an element; the family says the withdrawals): where the rule,
    as one test, no longer finds it significant, it is withdrawn and the new element is
    judged against the model before it."""
    if (without := getattr(run.fam, "without", None)) is None or len(state.named) < 2:
        return
    prev, win = state.named[-2:]
    parent = [state.base, *(h.fit for h in state.named)][-3]
    assert prev.fit is not None and parent is not None
    added = {e.name for e in prev.fit.model.effects} - {e.name for e in parent.model.effects}
    if len(added) != 1 or (alt := without(state.current, added.pop(), run.setup)) is None:
        return
    alt.extra["effect"] = state.current.extra["effect"]  # the new element's, as named
    again, alone = _judge(run, prev, alt, state.current), _judge(run, win, parent, alt)
    if again.significant or not alone.significant:
        return
    numbers = (again.p_value_corrected, again.delta_bic_corrected, again.heldout_reduction)
    state.withdrawn.append(Withdrawal(prev, f"{win.words} (named after it)", *numbers))
    state.named[-2:] = [alone]
    state.hypotheses = [alone if h is win else h for h in state.hypotheses]
    state.current = alt


def _judge(run: _Run, h: Hypothesis, parent: FitResult, ext: FitResult) -> Hypothesis:
    """``h``'s element judged by the family's rule, as one test, as the step from
    ``parent`` to ``ext`` (its signature record kept)."""
    said, comp = (h.kind, h.location, h.words, h.round), run.versus(parent, ext)
    sig = (h.signature_score, h.signature_evidence)
    out = Hypothesis.from_comparison(*said, parent, ext, comp, *sig)
    decide([out], 1, run.fam.rule)
    return out


def _hypothesis(run: _Run, state: Outcome, cand: str, sig: Any, rnd: int) -> Hypothesis:
    """The hypothesis of candidate ``cand`` (its screening record ``sig`` or None): the
    current model of ``state`` plus the element, refitted and judged by the family's
    refit checks; a refit that fails or is refused is a failed hypothesis (no fit)."""
    fam = run.fam
    kind, loc = split_candidate(cand)
    words = fam.words(cand, run.setup)
    score = float(sig.score) if sig is not None else float("nan")
    current = state.current
    try:
        ext = fam.refit(current, cand, sig, run.setup)
        judged = checks.Context(fam, run.setup, replace(state), fam.rule, refit=ext, candidate=cand)
        checks.refuse(judged)
    except (ValidationError, EvaluationError, np.linalg.LinAlgError) as exc:
        return Hypothesis.failed(kind, loc, words, rnd, str(exc), score)
    evidence = sig.evidence if sig is not None else ""
    comp = run.versus(current, ext)
    return Hypothesis.from_comparison(kind, loc, words, rnd, current, ext, comp, score, evidence)


def _diagnosis(run: _Run, ctx: checks.Context, channel: str) -> Diagnosis:
    """The :class:`Diagnosis` of a run whose checks have been folded into ``ctx``
    (``channel``: where the baseline's residual is largest)."""
    sp = run.setup.split
    found, outcome = ctx.found, ctx.outcome
    base, current, named = outcome.base, outcome.current, outcome.named
    amb = found.ambiguities
    baseline = baseline_summary(
        base, sp.fit_recordings, sp.heldout_recordings, sp.fit_masks, sp.heldout_masks
    )
    baseline.update(found.baseline)
    return Diagnosis(
        recording=", ".join(str(r.name) for r in sp.fit_recordings),
        family=run.fam.name,
        model=str(run.setup.model.family),
        holdout=sp.description,
        channel=channel,
        baseline=baseline,
        location=outcome.location,
        signatures=list(outcome.signatures),
        hypotheses=outcome.hypotheses,
        named=named,
        ambiguities=amb,
        verdict=verdict_words(named, outcome.hypotheses, amb, outcome.signatures, found),
        comparison=run.versus(base, current) if named else None,
        final_params=current.params(),
        seconds=time.perf_counter() - run.t0,
        rule=run.fam.rule,
        split=sp,
        base_fit=base,
        final_fit=current,
        findings=found.findings,
        confident=found.confident and bool(named),
        evidence=[a.sentence() for a in amb] + [x for x in found.sentences if x],
    )


def verdict_words(
    named: Sequence[Hypothesis],
    hypotheses: Sequence[Hypothesis],
    amb: Sequence[Ambiguity],
    signatures: Sequence[Any],
    found: Conclusion,
) -> str:
    """The verdict: "missing physics: A; then B" (with "(not confident)" when the
    checks say more is missing) and what cannot be separated, or "no significant missing
    physics" with the strongest candidate's numbers (a leading sentence of the checks
    stands in for it); then the checks' sentences (``found``)."""
    sentences = found.sentences
    if named:
        head = "missing physics" + ("" if found.confident else " (not confident)")
        text = f"{head}: " + "; then ".join(h.words for h in named)
        if amb:
            text += ". " + " ".join(a.sentence() for a in amb)
    elif found.leading and sentences:
        # nothing in the library explains what is left: the family's sentence says so
        text = ""
    else:
        text = "no significant missing physics"
        best = min(hypotheses, key=lambda h: h.p_value_corrected, default=None)
        if best is not None:
            z = best.comparison.heldout_z if best.comparison is not None else float("nan")
            z_words = f", held-out z = {z:+.1f}" if np.isfinite(z) else ""
            text += (
                f" (strongest candidate, {best.words}: corrected p = "
                f"{best.p_value_corrected:.2g}, held-out error change "
                f"{-100 * best.heldout_reduction:+.1f} %{z_words})"
            )
        elif signatures:
            top = signatures[0]
            text += (
                f" (no candidate passed the screen; strongest signature: {top.kind} "
                f"{float(top.score):.1f})"
            )
    for s in sentences:
        if s:
            lead = text.rstrip(". ") + ". " if text else ""
            text = lead + s[0].upper() + s[1:]
    return text


def make_family(name: str, **options: Any) -> DiagnosisFamily:
    """A diagnosis family by name with ``options`` for its constructor: ``"knc"``
    (:class:`~suspenv.diagnosis.knc.family.KncFamily`), ``"ride"``
    (:class:`~suspenv.diagnosis.ride.family.RideFamily`), or a component model family
    name such as ``"damper"`` (:class:`~suspenv.diagnosis.component.family.ComponentFamily`;
    see :func:`suspenv.models.components.make_component`). Only that family's modules
    are imported. (A road profile's family, :class:`~suspenv.diagnosis.road.RoadFamily`,
    is passed as an object: its module calls this one.)"""
    maker: type
    if name == "knc":
        from suspenv.diagnosis.knc.family import KncFamily

        maker = KncFamily
    elif name == "ride":
        from suspenv.diagnosis.ride.family import RideFamily

        maker = RideFamily
    else:
        from suspenv.diagnosis.component.family import ComponentFamily

        maker = ComponentFamily
        options = {"model": name, **options}
    allowed = [f.name for f in fields(maker) if f.init]
    if unknown := sorted(set(options) - set(allowed)):
        raise ValidationError(
            f"diagnosis family {name!r} has no option(s) {unknown}; its options are {allowed}"
        )
    return maker(**options)
