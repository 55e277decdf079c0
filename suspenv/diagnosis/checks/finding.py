"""What a check reads (:class:`Context`) and says (:class:`Finding`), and how findings
are folded into a family's conclusion (:func:`fold`); the checks are listed in
:mod:`suspenv.diagnosis.checks`."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.family import Conclusion, DiagnosisFamily, Outcome, Setup


@dataclass
class Context:
    """What a check reads: the family (to ask), the run's data and model, the search's
    outcome (its ``current`` is the final model after the family's own probes) and the
    decision rule."""

    family: DiagnosisFamily
    setup: Setup
    outcome: Outcome
    rule: DecisionRule


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


Check = Callable[[Context], Finding | None]


def fold(found: Conclusion, findings: Sequence[Finding]) -> None:
    """Add ``findings`` to a family's conclusion: each is kept by name, its sentence said
    (when it leads: after the family's leads, a later one before an earlier one), and the
    verdict made not confident where one says so."""
    for f in findings:
        found.findings[f.name] = f
        found.confident = found.confident and f.confident and not f.remains
        if f.sentence and f.lead:
            # after the family's own leads, which say more precisely what is left
            found.lead(f.sentence, found.leading)
        elif f.sentence:
            found.sentences.append(f.sentence)
