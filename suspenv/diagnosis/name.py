"""Name the missing physics: rank hypotheses with evidence, decide what is significant.

A hypothesis is "the model lacks effect K". Its evidence is (a) the residual
signature score of K's family (:mod:`suspenv.diagnosis.signatures`) and (b) the
refit with K added (:mod:`suspenv.diagnosis.refit`): the likelihood-ratio test
against the model without K, with the statistic corrected for serial correlation,
the BIC change and the held-out error change.

Decision rule (one criterion, stated once):
    K is *significant* when its corrected likelihood-ratio p-value is below
    ``alpha / (number of hypotheses tested)`` (Bonferroni), its corrected BIC falls,
    and the held-out data agree: by default the held-out RMS error falls by at least
    ``min_heldout_gain``; with ``heldout_rule="noise"`` the held-out gain in noise units
    is within ``heldout_z`` standard deviations of what a real effect of the fitted size
    would give (:attr:`~suspenv.diagnosis.evidence.Comparison.heldout_z`), so a change the
    held-out test can hardly see is judged on the fitted data alone. Where the caller
    sets ``strong_heldout_gain``, a hypothesis is also significant when the uncorrected
    test passes and the held-out error falls by at least that much (see :func:`decide`).
"No significant missing physics" is the verdict when no hypothesis is significant.

Ranking: significant hypotheses first, ordered by their reduction of the held-out
error (the test on data not used for fitting); hypotheses within two percentage
points of the best count as equally predictive and are ordered by the corrected BIC
change, so the element with fewer parameters wins a tie.

Two significant hypotheses of different families whose refits fit equally well
(corrected LR statistics within ``tie_tolerance``) cannot be separated by the data;
the report then names the test that would separate them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from suspenv.core.errors import ValidationError

#: effect kind (registry key) -> signature family
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
    "digressive_damping": "digressive",
    "damper_asymmetry": "damper_asymmetry",
    "asymmetric_digressive_damping": "damper_asymmetry",
    "maxwell_viscoelastic": "viscoelastic",
    "gas_spring": "spring",
    "kelvin_voigt": "spring",
    "force_offset": "sensor_offset",
    "sensor_offset": "sensor_offset",
    "sensor_gain": "sensor_gain",
    "sensor_lag": "sensor_lag",
    "lr_asymmetry": "lr_asymmetry",
}


def family_of(kind: str) -> str:
    """Signature family of an effect kind (the kind itself when unknown)."""
    return FAMILY_OF_KIND.get(kind, kind)


#: which test separates two families that the data at hand cannot tell apart
SEPARATING_TESTS: dict[frozenset[str], tuple[str, str]] = {
    frozenset({"friction", "sensor_offset"}): (
        "a hold at standstill plus slow constant-speed runs in each direction",
        "a constant offset acts at rest and alike in both directions; friction does not act "
        "at rest",
    ),
    frozenset({"friction", "hysteresis"}): (
        "small-amplitude cycles at several strokes",
        "hysteresis builds up over a displacement after each reversal; Coulomb friction steps "
        "at once",
    ),
    frozenset({"hysteresis", "viscoelastic"}): (
        "the same stroke at several frequencies",
        "a hysteresis loop keeps its width at any rate; a viscoelastic loop does not",
    ),
    frozenset({"progressive", "end_stop"}): (
        "a sweep of increasing amplitude on both sides",
        "a stop acts only beyond its gap and on one side",
    ),
    frozenset({"friction", "digressive"}): (
        "a very slow constant-speed run",
        "friction is fully present at the lowest speeds, a digressive knee is not",
    ),
    frozenset({"viscoelastic", "sensor_lag"}): (
        "a second, independent sensor on the same channel",
        "a sensor lag shifts the recorded signal, not the force in the part",
    ),
    frozenset({"damper_asymmetry", "sensor_offset"}): (
        "runs at several peak velocities",
        "an asymmetry grows with speed, an offset does not",
    ),
    frozenset({"spring", "sensor_offset"}): (
        "runs at several stroke offsets",
        "a spring force follows the displacement",
    ),
    frozenset({"friction", "damper_asymmetry"}): (
        "runs at several peak velocities",
        "friction does not grow with speed",
    ),
}


#: an effect that, on most data, equals a combination of two others (structural ambiguity)
EQUIVALENT_COMBINATIONS: dict[str, tuple[tuple[str, str], str]] = {
    # (f_pos + f_neg)/2 tanh(v/v_eps) + (f_pos - f_neg)/2 |tanh(v/v_eps)|: the second
    # term is a constant force wherever the carriage moves
    "directional_friction": (
        ("coulomb_friction", "force_offset"),
        "symmetric Coulomb friction plus a constant force offset",
    ),
}


#: an element whose parameters include another family's effect as a special part
#: (a gas spring's preload is a constant force offset)
CONTAINS: dict[str, tuple[str, ...]] = {
    "directional_friction": ("friction", "sensor_offset"),
    "gas_spring": ("spring", "sensor_offset"),
    "asymmetric_digressive_damping": ("digressive", "damper_asymmetry"),
}


def families_covered(kinds: Sequence[str]) -> set[str]:
    """Signature families the named kinds account for, structural equivalents included."""
    out: set[str] = set()
    for k in kinds:
        out.add(family_of(k))
        out.update(CONTAINS.get(k, ()))
    return out


def derived_values(kind: str, params: dict[str, dict[str, float]], name: str) -> dict[str, float]:
    """Values of the equivalent combination (e.g. Coulomb level and offset of a
    direction-dependent friction), for comparison with published figures."""
    if kind == "directional_friction":
        fp = params[f"{name}.f_pos"]["value"]
        fn = params[f"{name}.f_neg"]["value"]
        return {"coulomb_friction.f_c": 0.5 * (fp + fn), "force_offset.offset": 0.5 * (fp - fn)}
    return {}


def separating_test(fam_a: str, fam_b: str) -> tuple[str, str]:
    """(test, reason) that would separate two signature families."""
    return SEPARATING_TESTS.get(
        frozenset({fam_a, fam_b}),
        (
            "a test that excites the two differently (another amplitude, frequency or "
            "direction of motion)",
            "their signatures then differ",
        ),
    )


@dataclass
class Hypothesis:
    """One candidate missing effect with its evidence (JSON-friendly via ``to_dict``)."""

    kind: str
    family: str
    words: str
    round: int
    signature_score: float
    signature_evidence: str
    lr_statistic: float
    lr_statistic_corrected: float
    lr_dof: int
    p_value_corrected: float
    delta_bic_corrected: float
    heldout_reduction: float
    params: dict[str, dict[str, float]] = field(default_factory=dict)
    significant: bool = False
    fit: Any = field(default=None, repr=False)
    comparison: Any = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in ("fit", "comparison")} | (
            {"comparison": self.comparison.to_dict()} if self.comparison is not None else {}
        )


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
    """BIC change of the extended model from the corrected LR statistic (negative = better)."""
    return float(-lr_corrected + dof * np.log(max(n, 2)))


def decide(
    hyps: Sequence[Hypothesis],
    n_tested: int,
    alpha: float,
    min_heldout_gain: float,
    strong_heldout_gain: float | None = None,
    heldout_rule: str = "fraction",
    heldout_z: float = 2.0,
) -> None:
    """Set ``significant`` on each hypothesis by the module's decision rule.

    ``heldout_rule``: ``"fraction"`` asks the held-out RMS error to fall by at least
    ``min_heldout_gain``; ``"noise"`` asks the held-out gain in noise units not to fall
    more than ``heldout_z`` standard deviations short of a real effect's
    (``comparison.heldout_z >= -heldout_z``; one-sided 2.3 % at 2), which vetoes a
    refit the held-out test refutes and leaves one it cannot see to the fitted data.

    With ``strong_heldout_gain`` set, a hypothesis whose *uncorrected* test passes
    (p below the Bonferroni threshold and BIC falling) is also significant when it
    lowers the held-out error by at least that fraction: the serial-correlation
    correction is then too cautious because another missing effect still shapes the
    residual, and the held-out data carry the evidence.
    """
    if heldout_rule not in ("fraction", "noise"):
        raise ValidationError(f"heldout_rule must be 'fraction' or 'noise', got {heldout_rule!r}")
    threshold = alpha / max(n_tested, 1)
    for h in hyps:
        if heldout_rule == "noise" and h.comparison is not None:
            heldout_ok = h.comparison.heldout_z >= -heldout_z
        else:
            heldout_ok = h.heldout_reduction >= min_heldout_gain
        corrected = h.p_value_corrected < threshold and h.delta_bic_corrected < 0.0 and heldout_ok
        strong = False
        if strong_heldout_gain is not None and h.comparison is not None:
            p_raw = float(stats.chi2.sf(h.lr_statistic, max(h.lr_dof, 1)))
            strong = (
                p_raw < threshold
                and h.comparison.delta_bic < 0.0
                and h.heldout_reduction >= max(strong_heldout_gain, min_heldout_gain)
            )
        h.significant = bool(corrected or strong)


def rank(hyps: Sequence[Hypothesis], tie: float = 0.02) -> list[Hypothesis]:
    """Significant first. Among them, those whose held-out error reduction is within
    ``tie`` of the best are ranked by the corrected BIC change (most negative first:
    the simpler of two equally predictive elements wins), then the others by held-out
    reduction; the rest by BIC change."""
    sig = [h for h in hyps if h.significant]
    rest = sorted((h for h in hyps if not h.significant), key=lambda h: h.delta_bic_corrected)
    if not sig:
        return rest
    best = max(h.heldout_reduction for h in sig)
    lead = sorted(
        (h for h in sig if h.heldout_reduction >= best - tie), key=lambda h: h.delta_bic_corrected
    )
    chase = sorted(
        (h for h in sig if h.heldout_reduction < best - tie), key=lambda h: -h.heldout_reduction
    )
    return lead + chase + rest


def ambiguities(ranked: Sequence[Hypothesis], tie_tolerance: float = 0.05) -> list[Ambiguity]:
    """Pairs (the best vs each other significant family) that fit equally well."""
    sig = [h for h in ranked if h.significant]
    if len(sig) < 2:
        return []
    top = sig[0]
    out = []
    seen = {top.family}
    for h in sig[1:]:
        if h.family in seen:
            continue
        seen.add(h.family)
        gap = abs(top.lr_statistic_corrected - h.lr_statistic_corrected)
        # a runner-up with more parameters and no better fit merely nests the winner
        if h.lr_dof <= top.lr_dof and gap <= max(tie_tolerance * top.lr_statistic_corrected, 10.0):
            test, reason = separating_test(top.family, h.family)
            out.append(Ambiguity(top.kind, h.kind, top.words, h.words, test, reason))
    return out
