"""What a diagnosis family plugs into the one loop (:func:`suspenv.diagnosis.engine.diagnose`).

A family knows one kind of model and recording (a component on a dyno or rig, the
McPherson axle on a K&C rig, the minibus on ride tests). The loop owns the order of the
steps, the evidence (:func:`suspenv.diagnosis.evidence.compare`), the decision
(:mod:`suspenv.diagnosis.decision`), the hypothesis record and the verdict's words.
The family owns everything that depends on the model:

* ``prepare``: the split into fit and held-out data, the model, the candidate list;
* ``check_data`` (optional): the family's own data-sufficiency rules, run with the shared
  ones before any fitting (:func:`suspenv.diagnosis.sufficiency.check_setup`): a
  component's motion cycles, a K&C recording's whole loop;
* ``fit_baseline``: the plain model's fit (channel weights fixed here for the run);
* ``locate``: where the baseline's residual lives (a record with ``to_dict()``) and
  its main channel;
* ``screen``: score the open candidates against the current residual and choose which
  to refit (``Screening``);
* ``refit``: the current model plus one element, refitted;
* ``refit_checks`` (optional): the rules a refit must pass to stand as a hypothesis
  (:func:`suspenv.diagnosis.checks.refuse`);
* ``words``: the engineering words of a candidate;
* ``settle``: make a named winner ready to be the next round's null model (or None);
* ``ambiguities``: what the data cannot tell apart from a named element beyond the
  loop's own family-pair rule (read by :mod:`suspenv.diagnosis.checks.separability`);
* ``checks`` (optional): its own checks after the search (:mod:`suspenv.diagnosis.checks`:
  the K&C detection limits, the component family's probes);
* ``residual_left`` (optional): the family's noise model, which the shared rule judges
  (:mod:`suspenv.diagnosis.checks.residual_left`);
* ``assumptions`` (optional): the defaults used for what the recordings do not say
  (:mod:`suspenv.diagnosis.checks.assumptions`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.fitting import FitResult
from suspenv.diagnosis.hypothesis import Ambiguity, Hypothesis, Withdrawal
from suspenv.diagnosis.protocols import DiagnosableModel
from suspenv.diagnosis.split import Holdout, Recordings, Split


class Report(Protocol):
    """A record a report can print (a residual map, a signature, a check)."""

    def to_dict(self) -> dict[str, Any]: ...


@dataclass
class Setup:
    """One run's data and model, made by :meth:`DiagnosisFamily.prepare`.

    Attributes:
        split: fit and held-out data.
        model: the base model (no element added by the search).
        candidates: candidate names (``kind@location`` or a bare kind) the search may add.
    """

    split: Split
    model: DiagnosableModel
    candidates: list[str]


class SignatureLike(Protocol):
    """A screening record: what was scored (a signature family or a candidate), its
    score (larger = stronger evidence of the pattern), the evidence in words."""

    kind: str
    score: float
    evidence: str

    def to_dict(self) -> dict[str, Any]: ...


@dataclass
class Screening:
    """One round's screen: the signature records (for the report, strongest first) and
    the candidates chosen for a refit, each with the record its start values come from
    (None: no record)."""

    signatures: Sequence[SignatureLike]
    chosen: Sequence[tuple[str, SignatureLike | None]]


@dataclass
class Outcome:
    """What the search found, handed to the checks (:mod:`suspenv.diagnosis.checks`)."""

    base: FitResult
    current: FitResult
    named: list[Hypothesis]
    hypotheses: list[Hypothesis]
    signatures: Sequence[SignatureLike]
    location: Report
    #: elements withdrawn during the search: an element named after made them unneeded
    withdrawn: list[Withdrawal] = field(default_factory=list)


@dataclass
class Conclusion:
    """What a check concludes after the search (``family.checks()``, folded in by
    :func:`suspenv.diagnosis.checks.revise`), and what the checks concluded together.

    Attributes:
        named: elements a check names (each a refitted hypothesis).
        withdrawn: named elements a check withdraws (their reasons go to
            ``Hypothesis.withdrawn``, the records to the findings' ``withdrawn``).
        final_fit: the model after the check (None: unchanged).
        sentences: said after the verdict's main sentence.
        confident: False when a probe says something is still missing.
        findings: the checks' own records by name (``asymmetry``, ``beyond_library``,
            ``detection_limits``), kept on the :class:`~suspenv.diagnosis.engine.Diagnosis`.
        baseline: extra numbers of the baseline for the report.
    """

    named: list[Hypothesis] = field(default_factory=list)
    withdrawn: list[Withdrawal] = field(default_factory=list)
    final_fit: FitResult | None = None
    sentences: list[str] = field(default_factory=list)
    confident: bool = True
    findings: dict[str, Any] = field(default_factory=dict)
    baseline: dict[str, Any] = field(default_factory=dict)
    #: what the data cannot tell apart, and the test that would (said with the named)
    ambiguities: list[Ambiguity] = field(default_factory=list)
    #: how many sentences at the front are leads (:meth:`lead`)
    leading: int = 0

    def lead(self, sentence: str, at: int = 0) -> None:
        """Say ``sentence`` among the leading ones (at position ``at``): it says what is
        left outside the library and stands in for "no significant missing physics"."""
        self.sentences.insert(at, sentence)
        self.leading += 1


class DiagnosisFamily(Protocol):
    """The steps a family supplies to the loop (see the module docstring)."""

    #: short name: "component", "knc", "ride"
    name: str
    #: the decision rule of this family's reported benchmark
    rule: DecisionRule
    #: most elements added in turn
    max_effects: int

    def prepare(
        self, recordings: Recordings, holdout: Holdout, candidates: Sequence[str] | None
    ) -> Setup: ...

    def fit_baseline(self, setup: Setup) -> FitResult: ...

    def locate(self, base: FitResult, setup: Setup) -> tuple[Report, str]: ...

    def screen(
        self, current: FitResult, setup: Setup, open_candidates: Sequence[str], round_: int
    ) -> Screening: ...

    def refit(
        self, current: FitResult, candidate: str, signature: SignatureLike | None, setup: Setup
    ) -> FitResult: ...

    def words(self, candidate: str, setup: Setup) -> str: ...

    def settle(self, winner: FitResult, setup: Setup) -> FitResult | None: ...

    def ambiguities(
        self, winner: Hypothesis, ranked: Sequence[Hypothesis], parent: FitResult, setup: Setup
    ) -> list[Ambiguity]: ...


class OptionalSteps:
    """Defaults of a family's optional steps (a family class may inherit them): no settle,
    no ambiguities beyond the loop's family-pair rule, no checks after the search."""

    def settle(self, winner: FitResult, setup: Setup) -> FitResult | None:
        return None

    def ambiguities(
        self, winner: Hypothesis, ranked: Sequence[Hypothesis], parent: FitResult, setup: Setup
    ) -> list[Ambiguity]:
        return []
