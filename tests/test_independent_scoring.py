"""Scoring of the independent benchmark (benchmarks.independent_diagnosis).

Reference: the scoring rules of the module docstring, on hand-made truths and verdicts.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from benchmarks.independent_diagnosis import parameter_errors, score_case, summarise


def _diag(families, unexplained=False):
    return SimpleNamespace(
        named_families=list(families), unexplained=unexplained, verdict="v", seconds=1.0
    )


def _truth(kind, labels=()):
    return {
        "case_id": f"damper-{kind}-1",
        "family": "damper",
        "kind": kind,
        "effects": [{"label": lab} for lab in labels],
    }


def test_single_is_right_only_when_its_family_comes_first():
    assert score_case(_truth("single", ["friction"]), _diag(["friction", "hysteresis"]))["right"]
    assert not score_case(_truth("single", ["friction"]), _diag(["digressive", "friction"]))[
        "right"
    ]
    assert score_case(_truth("single", ["viscoelastic"]), _diag(["viscoelastic"]))["right"]


def _offset_truth(channel):
    return {
        "case_id": "friction_guide-single-1",
        "family": "friction_guide",
        "kind": "single",
        "effects": [{"label": "sensor_offset", "params": {"channel": channel}}],
    }


def test_an_offset_the_baseline_holds_is_right_only_when_the_verdict_reports_it():
    def diag(named=(), unexplained=False, offsets=()):
        d = _diag(named, unexplained)
        d.findings = {
            "baseline_offsets": [{"channel": ch, "significant": sig} for ch, sig in offsets]
        }
        return d

    truth = _offset_truth("force")
    row = score_case(truth, diag(offsets=[("force", True)]))
    assert row["right"] and row["baseline_offsets"] == ["force"]
    # not said to be off zero, said on another channel, or something named / unexplained
    assert not score_case(truth, diag(offsets=[("force", False)]))["right"]
    assert not score_case(truth, diag(offsets=[("position", True)]))["right"]
    assert not score_case(truth, diag(["friction"], offsets=[("force", True)]))["right"]
    assert not score_case(truth, diag(unexplained=True, offsets=[("force", True)]))["right"]
    # a recording without the finding (an older diagnosis) is a miss, not an error
    assert not score_case(truth, _diag([]))["right"]


def test_a_control_is_a_false_alarm_when_anything_is_named_or_unexplained():
    assert score_case(_truth("control"), _diag([]))["right"]
    assert not score_case(_truth("control"), _diag(["sensor_lag"]))["right"]
    assert not score_case(_truth("control"), _diag([], unexplained=True))["right"]


def test_outside_is_right_only_when_reported_unexplained_and_refusals_are_misses():
    assert score_case(_truth("outside", ["cubic_damper"]), _diag(["digressive"], True))["right"]
    assert not score_case(_truth("outside", ["cubic_damper"]), _diag(["digressive"]))["right"]
    refused = score_case(_truth("outside", ["backlash"]), None, "ValidationError: too short")
    assert not refused["right"] and refused["refused"]


def test_summary_counts_per_family_and_total():
    rows = []
    for kind, right in [("single", True), ("single", False), ("control", True), ("outside", True)]:
        r = score_case(_truth(kind, ["friction"]), _diag(["friction"] if right else ["x"]))
        r["right"] = right
        r["wall_s"] = r["cpu_s"] = 1.0
        rows.append(r)
    s = summarise({"cases": rows})
    assert s["damper"]["single_named_first"] == (1, 2)
    assert s["damper"]["control_false_alarms"] == (0, 1)
    assert s["all"]["outside_unexplained"] == (1, 1)


def test_a_stopped_run_resumes_from_its_rows(tmp_path):
    from benchmarks.independent_diagnosis import _finished

    rows = [{"case_id": "a", "right": True}, {"case_id": "x", "right": False}]
    text = "\n".join(json.dumps(r) for r in rows) + '\n{"case_id": "b", "rig'  # killed mid-write
    (tmp_path / "rows.jsonl").write_text(text)
    done = _finished(tmp_path, ["a", "b"])
    assert list(done) == ["a"]  # "x" is not a case of this run, "b" was cut off
    assert _finished(tmp_path / "missing", ["a"]) == {}


def _named(kind, **params):
    return SimpleNamespace(
        kind=kind, params={f"{kind}.{k}": {"value": v} for k, v in params.items()}
    )


def _effect(label, **params):
    return {"label": label, "params": params}


def test_parameters_compared_where_the_generator_law_has_a_counterpart():
    # golden values by hand from each law's definition (module docstring)
    fr = _effect("friction", variant="stribeck", Fc=40.0, fs_ratio=1.5)
    got = parameter_errors(fr, _named("stribeck_friction", f_c=44.0, f_s=60.0, v_s=0.01))
    assert got["f_c"]["rel_error"] == pytest.approx(0.1)
    assert got["f_s"]["true"] == pytest.approx(60.0) and got["f_s"]["rel_error"] == 0.0
    # a Coulomb element has no static level to compare
    assert set(parameter_errors(fr, _named("coulomb_friction", f_c=40.0))) == {"f_c"}
    mx = _effect("viscoelastic", variant="maxwell", km=2e4, tau=0.01)
    got = parameter_errors(mx, _named("maxwell_viscoelastic", k_m=2e4, c_m=300.0))
    assert got["k_m"]["rel_error"] == 0.0 and got["c_m"]["rel_error"] == pytest.approx(0.5)
    # a gain error is compared as the error, not as the gain near 1
    g = _effect("sensor_gain", variant="constant", gain_error=0.10)
    assert parameter_errors(g, _named("sensor_gain", gain=1.12))["gain_error"][
        "rel_error"
    ] == pytest.approx(0.2)
    # an extra damping in compression is the library's rebound term with the other sign
    a = _effect("damper_asymmetry", variant="one_side", side=1.0, dc=300.0)
    assert parameter_errors(a, _named("damper_asymmetry", dc_rebound=-300.0))["|dc_rebound|"][
        "rel_error"
    ] == pytest.approx(0.0)
    # laws without a counterpart are not compared
    bw = _effect("hysteresis", variant="bouc_wen", alpha=1e4, z_yield=1e-3)
    assert parameter_errors(bw, _named("bouc_wen_hysteresis", f_y=10.0, x_y=1e-3)) == {}


def test_an_end_stop_is_compared_side_by_side():
    bump = _effect("end_stop", variant="linear", bump=1.0, rebound=0.0, gap=0.02, ks=5e4)
    got = parameter_errors(bump, _named("bump_stop", gap=0.021, k_stop=4e4, p=1.0))
    assert got["gap"]["rel_error"] == pytest.approx(0.05)
    assert got["k_stop"]["rel_error"] == pytest.approx(0.2)
    # a rebound stop named for a bump stop: no parameter of the wrong side is compared
    assert parameter_errors(bump, _named("rebound_stop", gap=0.02, k_stop=5e4)) == {}
    both = _effect("end_stop", variant="linear", bump=1.0, rebound=1.0, gap=0.02, ks=5e4)
    pair = _named(
        "bump_and_rebound_stops", gap_bump=0.02, k_bump=5e4, gap_rebound=0.03, k_rebound=5e4
    )
    got = parameter_errors(both, pair)
    assert set(got) == {"gap_bump", "k_bump", "gap_rebound", "k_rebound"}
    assert got["gap_rebound"]["rel_error"] == pytest.approx(0.5)


def test_parameters_enter_the_row_and_the_summary_only_for_a_right_single():
    truth = {
        "case_id": "damper-single-1",
        "family": "damper",
        "kind": "single",
        "effects": [_effect("sensor_lag", variant="first_order", tau=0.01)],
    }
    d = _diag(["sensor_lag"])
    d.named = [_named("sensor_lag", tau=0.013)]
    row = score_case(truth, d)
    assert row["parameters"]["tau"]["rel_error"] == pytest.approx(0.3)
    wrong = _diag(["viscoelastic"])
    wrong.named = [_named("maxwell_viscoelastic", k_m=1.0, c_m=1.0)]
    assert "parameters" not in score_case(truth, wrong)
    row.update(wall_s=1.0, cpu_s=1.0)
    s = summarise({"cases": [row]})["all"]
    assert s["parameters_within_20_percent"] == (0, 1)
    assert s["parameter_error_median"] == pytest.approx(0.3)
