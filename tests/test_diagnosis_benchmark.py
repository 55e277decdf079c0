"""Blind-case generator and benchmark scoring (no diagnosis runs here)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.component_truth import make_case
from benchmarks.diagnosis_benchmark import _seeds, summarise
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.hypothesis import family_of


def test_cases_are_reproducible_and_conceal_their_truth() -> None:
    a, b = make_case("damper", 7, 1), make_case("damper", 7, 1)
    assert a.truth.to_dict() == b.truth.to_dict()
    np.testing.assert_array_equal(a.recording.outputs["force"], b.recording.outputs["force"])
    assert a.recording.meta["source"] == "synthetic blind case"
    assert "effects" not in a.recording.meta


@pytest.mark.parametrize("family", ["damper", "mr_damper", "friction_guide"])
def test_two_effect_cases_hold_two_families(family: str) -> None:
    for seed in range(3):
        case = make_case(family, seed, 2)
        fams = {family_of(k) for k in case.truth.kinds}
        assert len(fams) == 2
        assert 0.01 <= case.truth.noise_fraction <= 0.04


def test_no_effect_case_is_the_base_model_plus_noise() -> None:
    case = make_case("mr_damper", 3, 0)
    assert case.truth.effects == []
    # noise level stated in the truth: residual of the truth base model is that noise
    from suspenv.models.components import make_component

    m = make_component("mr_damper")
    clean = m.simulate(m.theta_from(case.truth.base), case.recording)["force"]
    noise = case.recording.outputs["force"] - clean
    assert np.std(noise) == pytest.approx(case.truth.noise_rms, rel=0.15)


def test_seed_sets_must_differ() -> None:
    with pytest.raises(ValidationError, match="must not overlap"):
        _seeds({"seeds_dev": [1, 2], "seeds_report": [2, 3]})
    assert _seeds({"seeds_dev": [1], "seeds_report": [2], "seed_set": "dev"}) == ([1], "dev")


def test_summary_counts() -> None:
    base = {"param_rel_errs": [], "seconds": 1.0, "heldout_reduction": 0.0, "family": "f"}
    rows = [
        base
        | {
            "n_true": 1,
            "top1_family_ok": True,
            "top1_kind_ok": False,
            "all_found": True,
            "false_alarm": False,
            "heldout_reduction": 0.8,
            "param_rel_errs": [0.1, 0.3],
        },
        base
        | {
            "n_true": 1,
            "top1_family_ok": False,
            "top1_kind_ok": False,
            "all_found": False,
            "false_alarm": False,
            "heldout_reduction": 0.4,
        },
        base
        | {
            "n_true": 0,
            "top1_family_ok": False,
            "top1_kind_ok": False,
            "all_found": True,
            "false_alarm": True,
        },
    ]
    s = summarise(rows)
    assert s["single_top1_family"] == 0.5
    assert s["control_false_alarm"] == 1.0
    assert s["median_heldout_reduction"] == pytest.approx(0.6)
    assert s["median_param_rel_err"] == pytest.approx(0.2)


def test_structural_equivalents_are_counted_only_where_they_hold() -> None:
    from benchmarks.diagnosis_benchmark import families_covered

    # direction-dependent friction = symmetric friction + a constant offset
    assert families_covered(["directional_friction"]) >= {"friction", "sensor_offset"}
    # plain Coulomb friction does not contain an offset
    assert "sensor_offset" not in families_covered(["coulomb_friction"])


def test_quarter_car_case_offsets_are_in_the_channel_unit() -> None:
    # every quarter car case carries the standard baseline's sensor zeros, one per channel,
    # each in its own channel's unit (m/s^2 and m)
    case = make_case("quarter_car_rig", 1, 1)
    assert "sensor_offset" not in case.truth.kinds  # baseline physics is never concealed
    offsets = {
        e["location"]: e["params"]["offset"]
        for e in case.truth.baseline
        if e["kind"] == "sensor_offset"
    }
    assert set(offsets) == {"body_acceleration", "suspension_deflection"}
    for channel, offset in offsets.items():
        y = case.recording.outputs[channel]
        amp = np.percentile(np.abs(y - np.median(y)), 98)
        # reference: the draw rule, 8-20 % of the channel's own amplitude (measured on the
        # recording, which also holds the concealed effect, hence the wider band)
        assert 0.03 * amp < abs(offset) < 0.4 * amp, (channel, offset, amp)
    assert case.recording.time[-1] < 2.6  # the shorter rig run of the benchmark


def test_separate_families_stay_out_of_the_totals() -> None:
    from benchmarks.diagnosis_benchmark import table_markdown

    row = {
        "param_rel_errs": [],
        "seconds": 1.0,
        "heldout_reduction": 0.0,
        "n_true": 1,
        "top1_family_ok": True,
        "top1_kind_ok": True,
        "all_found": True,
        "false_alarm": False,
    }
    rows = [
        row | {"family": "damper"},
        row | {"family": "quarter_car_rig", "top1_family_ok": False},
    ]
    main = summarise([r for r in rows if r["family"] != "quarter_car_rig"])
    assert main["single_top1_family"] == 1.0
    result = {
        "summary": main
        | {"seed_set": "dev", "seeds": [0], "separate_families": ["quarter_car_rig"]},
        "per_family": {"damper": summarise(rows[:1]), "quarter_car_rig": summarise(rows[1:])},
        "real": [],
    }
    text = table_markdown(result)
    assert "Totals leave out quarter_car_rig" in text
    assert "| quarter_car_rig | 1 | 0 % |" in text


def test_inseparable_pairs_are_scored_apart_from_the_strict_rate() -> None:
    from benchmarks.diagnosis_benchmark import case_record

    base = {"param_rel_errs": [], "seconds": 1.0, "heldout_reduction": 0.5, "family": "f"}
    single = base | {"n_true": 1, "top1_kind_ok": False, "all_found": False}
    rows = [
        # friction named first: right
        single | {"top1_family_ok": True, "top1_family_or_inseparable": True},
        # Dahl named first but reported inseparable from the true friction: honest
        single | {"top1_family_ok": False, "top1_family_or_inseparable": True},
        # wrong and no ambiguity reported
        single | {"top1_family_ok": False, "top1_family_or_inseparable": False},
    ]
    s = summarise(rows)
    assert s["single_top1_family"] == pytest.approx(1 / 3)
    assert s["single_top1_family_or_inseparable"] == pytest.approx(2 / 3)
    rec = case_record(
        rows[1]
        | {
            "case": "quarter_car_rig-1-0",
            "truth": "coulomb_friction",
            "named": "dahl_hysteresis",
            "cpu_seconds": 0.9,
        }
    )
    assert rec["truth"] == ["coulomb_friction"] and rec["named"] == ["dahl_hysteresis"]
    assert rec["cpu_seconds"] == 0.9 and rec["heldout_before"] is None
