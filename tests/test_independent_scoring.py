"""Scoring of the independent benchmark (suspenv.bench.independent_diagnosis).

Reference: the scoring rules of the module docstring, on hand-made truths and verdicts.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

from suspenv.bench.independent_diagnosis import score_case, summarise


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
    from suspenv.bench.independent_diagnosis import _finished

    rows = [{"case_id": "a", "right": True}, {"case_id": "x", "right": False}]
    text = "\n".join(json.dumps(r) for r in rows) + '\n{"case_id": "b", "rig'  # killed mid-write
    (tmp_path / "rows.jsonl").write_text(text)
    done = _finished(tmp_path, ["a", "b"])
    assert list(done) == ["a"]  # "x" is not a case of this run, "b" was cut off
    assert _finished(tmp_path / "missing", ["a"]) == {}
