"""The hypothesis record: "the model lacks effect K at location L", with its evidence.

Every diagnosis family builds its hypotheses here, from the refit that added the
element (:meth:`Hypothesis.from_comparison`) or from a refit that failed
(:meth:`Hypothesis.failed`), so the record, its JSON form and its words are the same
for components, K&C rig loops and ride recordings.

A candidate is written ``kind@location`` (``"dahl_hysteresis@top_mount"``,
``"bump_stop@rear_axle"``) or, where the model has one place for it (a component on a
dyno), the bare ``kind``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.diagnosis.evidence import Comparison
from suspenv.diagnosis.fitting import FitResult

#: effect kind (registry key of :mod:`suspenv.models.effects`) -> signature family:
#: effects of one family leave the same kind of residual and compete for one explanation
FAMILY_OF_KIND = {
    "coulomb_friction": "friction",
    "directional_friction": "friction",
    "stribeck_friction": "friction",
    "lugre_friction": "friction",
    "dahl_hysteresis": "hysteresis",
    "bouc_wen_hysteresis": "hysteresis",
    "cubic_stiffness": "progressive",
    "progressive_stiffness": "progressive",
    "bump_stop": "end_stop",
    "rebound_stop": "end_stop",
    "bump_and_rebound_stops": "end_stop",
    "digressive_damping": "digressive",
    "damper_asymmetry": "damper_asymmetry",
    "asymmetric_digressive_damping": "damper_asymmetry",
    "maxwell_viscoelastic": "viscoelastic",
    "gas_spring": "spring",
    "kelvin_voigt": "spring",
    "force_offset": "sensor_offset",
    "sensor_offset": "sensor_offset",
    "zero_drift": "sensor_offset",
    "sensor_gain": "sensor_gain",
    "sensor_lag": "sensor_lag",
    "lr_asymmetry": "lr_asymmetry",
}

LOCATION_SEPARATOR = "@"


def family_of(kind: str) -> str:
    """Signature family of an effect kind (the kind itself when it has none)."""
    return FAMILY_OF_KIND.get(kind, kind)


def candidate_name(kind: str, location: str = "") -> str:
    """``kind@location`` (the bare kind when ``location`` is empty)."""
    return f"{kind}{LOCATION_SEPARATOR}{location}" if location else kind


def split_candidate(candidate: str) -> tuple[str, str]:
    """``(kind, location)`` of a candidate name (location "" for a bare kind)."""
    kind, _, location = candidate.partition(LOCATION_SEPARATOR)
    return kind, location


def element_params(refit: FitResult) -> dict[str, dict[str, float]]:
    """The fitted parameters of the element ``refit`` added (named
    ``refit.extra["effect"]["name"]``)."""
    prefix = str(refit.extra["effect"]["name"]) + "."
    return {k: v for k, v in refit.params().items() if k.startswith(prefix)}


@dataclass
class Hypothesis:
    """One candidate missing effect with its evidence (JSON-friendly via ``to_dict``).

    Attributes:
        kind: effect kind (a key of the effects library).
        location: where the element was placed ("" where the model has one place).
        family: signature family of ``kind`` (:func:`family_of`).
        words: engineering words, e.g. "rubber bushing hysteresis (Dahl) in the top mount".
        round: search round in which it was refitted (1 = against the baseline).
        signature_score: screening score of the residual signature (NaN: not screened).
        signature_evidence: the signature's numbers in words.
        lr_statistic / lr_statistic_corrected / lr_dof / p_value_corrected: the
            likelihood-ratio test of the refit against the model without the element,
            raw and corrected for serial correlation.
        delta_bic_corrected: BIC change from the corrected statistic (negative: better).
        heldout_reduction: relative drop of the held-out RMS error (0.1 = 10 % lower).
            The evidence fields default to a refit that gained nothing.
        params: the element's own fitted parameters ``{name: {value, stderr, ...}}``.
        significant: set by :func:`suspenv.diagnosis.decision.decide`.
        withdrawn: why a named hypothesis was withdrawn after the search, by a family's
            checks (e.g. judged again beside a delay found later); "" when it was not.
        fit / comparison: the refit and its comparison with the model it extends.
    """

    kind: str
    location: str
    family: str
    words: str
    round: int
    signature_score: float
    signature_evidence: str
    lr_statistic: float = 0.0
    lr_statistic_corrected: float = 0.0
    lr_dof: int = 0
    p_value_corrected: float = 1.0
    delta_bic_corrected: float = float("inf")
    heldout_reduction: float = 0.0
    params: dict[str, dict[str, float]] = field(default_factory=dict)
    significant: bool = False
    withdrawn: str = ""
    fit: FitResult | None = field(default=None, repr=False)
    comparison: Comparison | None = field(default=None, repr=False)

    @property
    def candidate(self) -> str:
        """The candidate name, ``kind@location`` (bare kind without a location)."""
        return candidate_name(self.kind, self.location)

    @classmethod
    def from_comparison(
        cls,
        kind: str,
        location: str,
        words: str,
        round_: int,
        parent: FitResult,
        refit: FitResult,
        comparison: Comparison,
        signature_score: float = float("nan"),
        signature_evidence: str = "",
    ) -> Hypothesis:
        """The hypothesis of a refit ``refit`` (``parent`` plus the element), whose
        element is named ``refit.extra["effect"]["name"]``."""
        lr = comparison.lr
        dbic = corrected_delta_bic(lr.statistic_corrected, lr.dof, parent.n_samples)
        return cls(
            kind=kind,
            location=location,
            family=family_of(kind),
            words=words,
            round=round_,
            signature_score=float(signature_score),
            signature_evidence=signature_evidence,
            lr_statistic=lr.statistic,
            lr_statistic_corrected=lr.statistic_corrected,
            lr_dof=lr.dof,
            p_value_corrected=lr.p_value_corrected,
            delta_bic_corrected=dbic,
            heldout_reduction=comparison.heldout_reduction,
            params=element_params(refit),
            fit=refit,
            comparison=comparison,
        )

    @classmethod
    def failed(
        cls,
        kind: str,
        location: str,
        words: str,
        round_: int,
        reason: str,
        signature_score: float = float("nan"),
    ) -> Hypothesis:
        """A candidate whose refit could not be computed (never significant: the
        evidence fields keep their defaults, no likelihood gained)."""
        why = f"refit failed: {reason}"
        return cls(kind, location, family_of(kind), words, round_, float(signature_score), why)

    def own_params(self) -> dict[str, dict[str, float]]:
        """The element's own parameters of the current ``fit`` (after a settle)."""
        return dict(self.params) if self.fit is None else element_params(self.fit)

    def to_dict(self) -> dict[str, Any]:
        out = {k: v for k, v in self.__dict__.items() if k not in ("fit", "comparison")}
        out["candidate"] = self.candidate
        if self.comparison is not None:
            out["comparison"] = self.comparison.to_dict()
        return out


@dataclass
class Ambiguity:
    """Two hypotheses the data cannot separate, and the test that would."""

    a: str
    b: str
    words_a: str
    words_b: str
    test: str
    reason: str = ""

    def sentence(self) -> str:
        why = f" ({self.reason})" if self.reason else ""
        return (
            f"cannot separate {self.words_a} from {self.words_b} with this data; "
            f"{self.test} would{why}"
        )

    def to_dict(self) -> dict[str, str]:
        return dict(self.__dict__) | {"sentence": self.sentence()}


def corrected_delta_bic(lr_corrected: float, dof: int, n: int) -> float:
    """BIC change of the extended model from the corrected LR statistic (negative = better):
    ``-LR_c + dof * ln(n)``."""
    return float(-lr_corrected + dof * np.log(max(n, 2)))


@dataclass
class Withdrawal:
    """A named element withdrawn by a check after the search: judged again beside what
    the check found (a delay of the recording, a zero drift of more shape), no longer
    significant.

    Attributes:
        hypothesis: the element as it was named.
        beside: what it was judged again beside, in words (e.g. "the delay of the force
            found after it").
        p_value_corrected, delta_bic_corrected: the element's likelihood-ratio test
            (serial-correlation corrected) and corrected BIC change against the model
            with that and without the element.
        heldout_reduction: the relative drop of the held-out RMS error the element gives
            there (NaN where the check does not judge held-out data).
        beside_delay: judged beside a delay (its sentence follows the delay's).
    """

    hypothesis: Hypothesis
    beside: str
    p_value_corrected: float
    delta_bic_corrected: float
    heldout_reduction: float = float("nan")
    beside_delay: bool = False

    def to_dict(self) -> dict[str, Any]:
        h = self.hypothesis
        own = {k: v for k, v in self.__dict__.items() if k not in ("hypothesis", "beside_delay")}
        head = {"candidate": h.candidate, "words": h.words, "round": h.round}
        return head | own | {"sentence": self.sentence()}

    def sentence(self) -> str:
        """One sentence for the verdict."""
        held = (
            ""
            if math.isnan(self.heldout_reduction)  # not judged
            else f", held-out error {-100 * self.heldout_reduction:+.1f} %"
        )
        return (
            f"{self.hypothesis.words}, named in round {self.hypothesis.round}, is withdrawn: "
            f"beside {self.beside} it is no longer significant (corrected p = "
            f"{self.p_value_corrected:.2g}, corrected BIC change "
            f"{self.delta_bic_corrected:+.3g}{held})"
        )
