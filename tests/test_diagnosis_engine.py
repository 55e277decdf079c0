"""The diagnosis engine end to end on concealed (blind) cases, the report, the CLI.

References: the truth of each blind case is the effect list the generator
concealed (kept apart from the case recording), so every assertion compares the
blind diagnosis with an independent fact.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from suspenv.diagnosis.blind import make_case, write_case
from suspenv.diagnosis.engine import diagnose, motion, split
from suspenv.diagnosis.name import Hypothesis, ambiguities, family_of
from suspenv.recordings import load_recording


@pytest.mark.slow
def test_single_effect_named_and_fit_improves() -> None:
    # development seed 1 of the damper family conceals a force offset
    case = make_case("damper", 1, 1)
    assert case.truth.kinds == ["force_offset"]
    diag = diagnose(case.recording, "damper")
    assert diag.named_kinds[:1] == ["force_offset"]
    assert diag.comparison is not None and diag.comparison.heldout_reduction > 0.5
    true = case.truth.effects[0]["params"]["offset"]
    assert diag.named[0].params["force_offset.offset"]["value"] == pytest.approx(true, rel=0.05)
    assert diag.seconds < 30.0


def test_no_effect_control_is_not_claimed() -> None:
    case = make_case("mr_damper", 0, 0)
    diag = diagnose(case.recording, "mr_damper")
    assert diag.named == []
    assert diag.verdict.startswith("no significant missing physics")


def test_two_effects_both_found() -> None:
    case = make_case("damper", 1, 2)  # dahl hysteresis + digressive curve
    diag = diagnose(case.recording, "damper")
    assert {family_of(k) for k in case.truth.kinds} == set(diag.named_families)


def test_holdout_fraction_and_recordings() -> None:
    case = make_case("damper", 2, 0)
    sp = split(case.recording, 0.25)
    n = case.recording.n_samples
    assert sp.fit_masks[0].sum() == round(0.75 * n)
    assert not np.any(sp.fit_masks[0] & sp.heldout_masks[0])
    with pytest.raises(ValueError, match="0 < holdout < 1"):
        split(case.recording, 1.5)
    x, v = motion(case.recording)
    assert x.shape == v.shape == case.recording.time.shape


def _hyp(kind: str, lr: float, dof: int) -> Hypothesis:
    return Hypothesis(
        kind, family_of(kind), kind, 1, 0.5, "", lr, lr, dof, 0.0, -lr, 0.5, significant=True
    )


def test_ambiguity_needs_equal_fit_and_no_extra_parameters() -> None:
    top = _hyp("coulomb_friction", 1000.0, 1)
    # equal fit, same number of parameters, another family: cannot be separated
    amb = ambiguities([top, _hyp("force_offset", 995.0, 1)])
    assert len(amb) == 1 and "would" in amb[0].sentence()
    # clearly worse fit: separated
    assert ambiguities([top, _hyp("force_offset", 500.0, 1)]) == []
    # equal fit only by adding parameters: it nests the winner, no ambiguity
    assert ambiguities([top, _hyp("dahl_hysteresis", 1000.0, 2)]) == []


def test_blind_case_through_the_cli(tmp_path) -> None:
    from suspenv.cli.main import main

    # development seed 1 of the MR damper family conceals Coulomb friction
    case = make_case("mr_damper", 1, 1)
    rec_path, truth_path = write_case(case, tmp_path / "cases", tmp_path / "truth")
    # the case file does not say what was added; the truth file (kept apart) does
    for kind in case.truth.kinds:
        assert kind.encode() not in rec_path.read_bytes()
    assert json.loads(truth_path.read_text())["effects"][0]["kind"] == "coulomb_friction"
    assert load_recording(rec_path).outputs.keys() == {"force"}

    out = tmp_path / "out"
    assert main(["diagnose", str(rec_path), "--model", "mr_damper", "--out", str(out)]) == 0
    md = (out / "report.md").read_text()
    assert "Verdict" in md and "Hypotheses" in md and "residual_map.png" in md
    found = json.loads((out / "diagnosis.json").read_text())
    assert found["named"][0]["kind"] == "coulomb_friction"
    assert found["comparison"]["heldout_reduction"] > 0.5
    f_c = found["named"][0]["params"]["coulomb_friction.f_c"]["value"]
    assert f_c == pytest.approx(case.truth.effects[0]["params"]["f_c"], rel=0.2)
    # an unknown recording name is refused with the rule
    assert main(["diagnose", "nonsense", "--out", str(out)]) == 2
