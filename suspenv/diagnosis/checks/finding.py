"""What a check reads (:class:`Context`) and says (a :class:`Finding` or a
:class:`~suspenv.diagnosis.family.Conclusion`), and how it is folded in (:func:`fold`);
the checks are listed in :mod:`suspenv.diagnosis.checks`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.family import Conclusion, DiagnosisFamily, Outcome, Setup
from suspenv.diagnosis.fitting import FitResult


@dataclass
class Context:
    """What a check reads: the family (to ask), the run's data and model, the search's
    outcome as the checks before this one left it, the decision rule and what they
    concluded (``found``). A refit check (during the search) also reads the refit under
    judgement (``refit``: ``outcome.current`` plus the element of ``candidate``)."""

    family: DiagnosisFamily
    setup: Setup
    outcome: Outcome
    rule: DecisionRule
    found: Conclusion = field(default_factory=Conclusion)
    refit: FitResult | None = None
    candidate: str = ""


@dataclass
class Finding:
    """One check's result.

    Attributes:
        name: the check's name (the key of the diagnosis' ``findings``).
        remains: a residual above the family's noise rule is left unexplained.
        confident: False when the verdict may not name an element with confidence.
        sentence: said after the verdict's main sentence ("" for nothing).
        lead: the sentence leads the verdict and stands in for "no significant missing
            physics".
        numbers: the check's numbers (JSON-ready).
        record: the family's own record behind the numbers (``to_dict()`` where it has
            one; the residual left's: the family's noise-model numbers).
    """

    name: str
    remains: bool = False
    confident: bool = True
    sentence: str = ""
    lead: bool = False
    numbers: dict[str, Any] = field(default_factory=dict)
    record: Any = None

    def short(self) -> str:
        """The residual left in a few words (the headline's)."""
        n = self.numbers
        if "short" in n:
            return str(n["short"])
        if "worst_rms" not in n:
            return self.name
        return f"{n['worst_rms']:.3g} x noise in {n['worst_channel']}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "remains": self.remains,
            "confident": self.confident,
            "sentence": self.sentence,
            **self.numbers,
            **({"record": jsonable(self.record)} if self.record is not None else {}),
        }


def jsonable(v: Any) -> Any:
    if isinstance(v, list | tuple):
        return [jsonable(x) for x in v]
    return v.to_dict() if hasattr(v, "to_dict") else v


Check = Callable[[Context], Finding | Conclusion | None]


def fold(ctx: Context, result: Finding | Conclusion | None) -> None:
    """Add one check's result to ``ctx``: a :class:`Finding` is kept by name, its sentence
    said (when it leads: after the leads before it) and the verdict made not confident
    where it says so; a :class:`~suspenv.diagnosis.family.Conclusion`: :func:`revise`."""
    if not isinstance(result, Finding):
        return revise(ctx, result) if result is not None else None
    found, f = ctx.found, result
    found.findings[f.name] = f
    found.confident = found.confident and f.confident and not f.remains
    if f.sentence and f.lead:
        # after the family's own leads, which say more precisely what is left
        found.lead(f.sentence, found.leading)
    elif f.sentence:
        found.sentences.append(f.sentence)


def revise(ctx: Context, part: Conclusion) -> None:
    """Fold a family check's conclusion into ``ctx``: the elements it names join the named
    and the hypotheses, those it withdraws leave the named, its ``final_fit`` becomes the
    current model; its leads go before the leads so far, its other sentences last, its
    look-alikes after those so far; its records are kept by name (a list extends the
    list of that name)."""
    o, found = ctx.outcome, ctx.found
    for w in part.withdrawn:
        w.hypothesis.withdrawn = w.sentence()
    if part.withdrawn:
        part.findings = {"withdrawn": part.withdrawn, **part.findings}
    gone = {id(w.hypothesis) for w in part.withdrawn}
    named = [h for h in [*o.named, *part.named] if id(h) not in gone]
    current = part.final_fit or o.current
    ctx.outcome = replace(o, current=current, named=named, hypotheses=[*o.hypotheses, *part.named])
    found.sentences[:0] = part.sentences[: part.leading]
    found.sentences += part.sentences[part.leading :]
    found.leading += part.leading
    found.confident = found.confident and part.confident
    found.ambiguities += part.ambiguities
    found.baseline.update(part.baseline)
    for k, v in part.findings.items():
        have = found.findings.get(k)
        if isinstance(have, list) and isinstance(v, list):
            have += v
        else:
            found.findings[k] = v
