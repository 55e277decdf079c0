"""The decision rule's multiple-testing correction and the hypothesis record.

References: the Bonferroni bound (the family-wise error rate of m tests each at level
alpha / m is at most alpha) and, for independent uniform p-values under the null, the
exact rate 1 - (1 - alpha / m)^m.
"""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.decision import DecisionRule, decide, rank
from suspenv.diagnosis.hypothesis import Hypothesis, candidate_name, split_candidate


def _hyp(p: float, kind: str = "coulomb_friction", location: str = "") -> Hypothesis:
    return Hypothesis(
        kind=kind,
        location=location,
        family="friction",
        words=kind,
        round=1,
        signature_score=1.0,
        signature_evidence="",
        lr_statistic=50.0,
        lr_statistic_corrected=50.0,
        lr_dof=1,
        p_value_corrected=p,
        delta_bic_corrected=-10.0,
        heldout_reduction=0.5,
    )


def test_threshold_is_alpha_over_the_candidates_screened():
    rule = DecisionRule(alpha=0.01)
    assert rule.threshold(1) == pytest.approx(0.01)
    assert rule.threshold(8) == pytest.approx(0.01 / 8)  # Bonferroni: alpha / m
    # a p-value between alpha / m and alpha is significant alone, not among m screened
    h = _hyp(0.004)
    decide([h], 1, rule)
    assert h.significant
    decide([h], 5, rule)
    assert not h.significant


def test_family_wise_error_rate_under_the_null_is_held_at_alpha():
    # m true-null candidates per round, p-values independent uniform: the rate of rounds
    # that name anything must match 1 - (1 - alpha / m)^m <= alpha (and not the
    # uncorrected 1 - (1 - alpha)^m, which is about m times larger)
    rng = np.random.default_rng(7)
    alpha, m, rounds = 0.05, 8, 20000
    rule = DecisionRule(alpha=alpha)
    named = 0
    for p_values in rng.uniform(size=(rounds, m)):
        hyps = [_hyp(float(p)) for p in p_values]
        decide(hyps, m, rule)
        named += any(h.significant for h in hyps)
    rate = named / rounds
    exact = 1.0 - (1.0 - alpha / m) ** m
    se = np.sqrt(exact * (1.0 - exact) / rounds)
    assert abs(rate - exact) < 4 * se
    assert rate <= alpha + 4 * se
    uncorrected = 1.0 - (1.0 - alpha) ** m
    assert rate < 0.5 * uncorrected


def test_rule_errors_name_the_rule_and_the_value():
    with pytest.raises(ValidationError, match=r"0 < alpha < 1.*alpha=1.5"):
        DecisionRule(alpha=1.5)
    with pytest.raises(ValidationError, match="heldout_rule.*'chi2'"):
        DecisionRule(heldout_rule="chi2")


def test_ranking_puts_the_simpler_of_two_equally_predictive_elements_first():
    a, b = _hyp(1e-9), _hyp(1e-9, "directional_friction")
    a.significant = b.significant = True
    b.delta_bic_corrected = -30.0  # fits better at equal held-out gain
    assert rank([a, b])[0] is b
    b.heldout_reduction = 0.3  # clearly less predictive: the other wins
    assert rank([a, b])[0] is a


def test_candidate_names_round_trip():
    assert candidate_name("bump_stop", "rear_axle") == "bump_stop@rear_axle"
    assert candidate_name("coulomb_friction") == "coulomb_friction"
    assert split_candidate("dahl_hysteresis@top_mount") == ("dahl_hysteresis", "top_mount")
    assert split_candidate("sensor_gain") == ("sensor_gain", "")
    assert _hyp(0.1, "dahl_hysteresis", "lower_arm").candidate == "dahl_hysteresis@lower_arm"


def test_engine_divides_alpha_by_every_open_candidate_not_only_those_refitted(monkeypatch):
    # the damper family refits only the candidates of its strongest signature families;
    # the Bonferroni denominator must still be every candidate open in the round
    import suspenv.diagnosis.engine as engine
    from benchmarks.component_truth import make_case

    seen: list[tuple[int, int]] = []
    real_decide = engine.decide

    def spy(hyps, n_screened, rule):
        seen.append((len(hyps), n_screened))
        real_decide(hyps, n_screened, rule)

    monkeypatch.setattr(engine, "decide", spy)
    case = make_case("damper", 7, 0)
    family = engine.make_family("damper", max_effects=1, screen_families=1)
    engine.diagnose(case.recording, family, holdout=0.3)
    n_candidates = len(family.prepare(case.recording, 0.3, None).candidates)
    assert seen, "decide was not called"
    refitted, screened = seen[0]
    assert screened == n_candidates
    assert refitted < screened
