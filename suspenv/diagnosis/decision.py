"""Decide which hypotheses are significant, rank them, and say what the data cannot separate.

Decision rule (one criterion, stated once, for every diagnosis family):
    a hypothesis is *significant* when its serial-correlation-corrected
    likelihood-ratio p-value is below ``alpha / m`` (Bonferroni), its corrected BIC
    falls, and the held-out data agree (:class:`DecisionRule`).

The multiple-testing correction. ``m`` is the number of candidates *screened* in the
round, not the number refitted. The screen looks at the same residual as the test, so
refitting only the best-looking few and dividing ``alpha`` by that few would spend the
family-wise error rate on a choice already made from the data. Dividing by every
candidate the round could have named keeps the family-wise level at ``alpha`` whatever
the screen kept. It costs little power: a real effect's corrected p-value is usually
many orders of magnitude below ``alpha``, and ``log(m)`` grows slowly.

Held-out agreement. ``"fraction"``: the held-out RMS error falls by at least
``min_heldout_gain``. ``"noise"``: the held-out gain in noise units is within
``heldout_z`` standard deviations of what a real effect of the fitted size would give
(:attr:`~suspenv.diagnosis.evidence.Comparison.heldout_z`). So the held-out data veto
a refit they refute, and a change they can hardly see is judged on the fitted data
alone. With ``strong_heldout_gain`` set, a hypothesis is also significant when the
*uncorrected* test passes and the held-out error falls by at least that much. The
serial-correlation correction is too cautious while another missing effect still
shapes the residual, and then the held-out data carry the evidence.

Ranking (:func:`rank`): significant hypotheses first, by their reduction of the held-out
error; the element with fewer parameters wins a tie.

"No significant missing physics" is the verdict when no hypothesis is significant.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from scipy import stats

from suspenv.core.errors import ValidationError
from suspenv.core.options import number
from suspenv.diagnosis.hypothesis import Ambiguity, Hypothesis
from suspenv.diagnosis.record import Record

HELDOUT_RULES = ("fraction", "noise")

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

#: pairs that a force switched by an input the recording does not carry makes
#: inseparable on the channel its gains are profiled out of (:func:`ambiguities`): whether
#: that force passes a sensor's lag is not known, and a lag of the rest of the force
#: beside it unlagged is a viscoelastic branch beside a damping
UNRECORDED_ALIKE: frozenset[frozenset[str]] = frozenset({frozenset({"viscoelastic", "sensor_lag"})})

#: an effect that, on most data, equals a combination of two others (structural ambiguity)
EQUIVALENT_COMBINATIONS: dict[str, tuple[tuple[str, str], str]] = {
    # (f_pos + f_neg)/2 tanh(v/v_eps) + (f_pos - f_neg)/2 |tanh(v/v_eps)|: the second
    # term is a constant force wherever the carriage moves
    "directional_friction": (
        ("coulomb_friction", "force_offset"),
        "symmetric Coulomb friction plus a constant force offset",
    ),
}


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


@dataclass(frozen=True)
class DecisionRule(Record):
    """The decision rule's settings (see the module docstring).

    Attributes:
        alpha: family-wise significance level of a round (Bonferroni over the
            candidates screened in it).
        heldout_rule: ``"fraction"`` or ``"noise"``.
        min_heldout_gain: least relative drop of the held-out RMS error
            (``"fraction"``; also the floor of ``strong_heldout_gain``).
        heldout_z: how many standard deviations short of a real effect's held-out gain
            a refit may fall (``"noise"``; one-sided 2.3 % at 2).
        strong_heldout_gain: a held-out drop this large also lets the uncorrected test
            decide (None: only the corrected test).
    """

    alpha: float = 0.01
    heldout_rule: str = "fraction"
    min_heldout_gain: float = 0.01
    heldout_z: float = 2.0
    strong_heldout_gain: float | None = None

    def __post_init__(self) -> None:
        number("decision rule", "alpha", self.alpha, 0.0, 1.0, lo_open=True, hi_open=True)
        if self.heldout_rule not in HELDOUT_RULES:
            raise ValidationError(
                f"heldout_rule must be one of {HELDOUT_RULES}, but got {self.heldout_rule!r}"
            )
        if not self.heldout_z > 0.0:
            raise ValidationError(f"`heldout_z > 0` must hold, but got {self.heldout_z}")

    def threshold(self, n_screened: int) -> float:
        """The per-hypothesis p-value threshold ``alpha / n_screened`` (Bonferroni)."""
        return self.alpha / max(int(n_screened), 1)


def decide(hyps: Sequence[Hypothesis], n_screened: int, rule: DecisionRule) -> None:
    """Set ``significant`` on each hypothesis of a round by ``rule``; ``n_screened`` is
    the number of candidates screened in that round (the Bonferroni denominator)."""
    threshold = rule.threshold(n_screened)
    for h in hyps:
        if rule.heldout_rule == "noise" and h.comparison is not None:
            heldout_ok = h.comparison.heldout_z >= -rule.heldout_z
        else:
            heldout_ok = h.heldout_reduction >= rule.min_heldout_gain
        corrected = h.p_value_corrected < threshold and h.delta_bic_corrected < 0.0 and heldout_ok
        strong = False
        if rule.strong_heldout_gain is not None and h.comparison is not None:
            p_raw = float(stats.chi2.sf(h.lr_statistic, max(h.lr_dof, 1)))
            strong = (
                p_raw < threshold
                and h.comparison.delta_bic < 0.0
                and h.heldout_reduction >= max(rule.strong_heldout_gain, rule.min_heldout_gain)
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


#: two refits of one parent fit alike when their likelihood-ratio statistics differ by at
#: most TIE_SHARE of the first's or TIE_LR (:func:`fit_alike`)
TIE_SHARE = 0.05
TIE_LR = 10.0


def fit_alike(lr: float, other: float) -> bool:
    """Whether a refit of likelihood-ratio statistic ``other`` fits as well as one of
    ``lr`` (both against one parent): ``|lr - other| <= max(TIE_SHARE lr, TIE_LR)``."""
    return abs(lr - other) <= max(TIE_SHARE * lr, TIE_LR)


def ambiguities(ranked: Sequence[Hypothesis], profiled: str | None = None) -> list[Ambiguity]:
    """Pairs (the best vs each other significant family) that fit alike (:func:`fit_alike`)
    or, where the fits profile an unrecorded input out of the channel ``profiled``, that
    it makes inseparable there (:data:`UNRECORDED_ALIKE`, both on that channel)."""
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
        alike = fit_alike(top.lr_statistic_corrected, h.lr_statistic_corrected) or (
            frozenset({top.family, h.family}) in UNRECORDED_ALIKE
            and profiled is not None
            and {top.location, h.location} <= {"", profiled}
        )
        # a runner-up with more parameters and no better fit merely nests the winner
        if h.lr_dof <= top.lr_dof and alike:
            test, reason = separating_test(top.family, h.family)
            out.append(Ambiguity(top.candidate, h.candidate, top.words, h.words, test, reason))
    return out
