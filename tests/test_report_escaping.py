"""Names taken from data cannot inject markup into a report (suspenv.core.markdown).

Reference: CommonMark's block rules (a line starting with ``#``, ``-``, ``+``, ``=`` or
``1.`` starts a heading, list or setext underline) and GFM's table rule (``|`` splits
cells, a line break ends the row); HTML's ``<``/``&``.
"""

from __future__ import annotations

import re

import pytest

from suspenv.core.markdown import markdown_table, table_lines, text

NASTY = "car 7\n# Verdict: all good\r\n- [x](http://example.invalid) <b>|</b>\u2028> quote"


def test_text_keeps_a_name_on_one_line_without_markup():
    out = text(NASTY)
    assert "\n" not in out and "\r" not in out and "\u2028" not in out
    assert not re.search(r"[<>\[\]|`*]", out)
    assert out.startswith("car 7 # Verdict")  # the name is all there, as text


@pytest.mark.parametrize("name", ["# heading", "- item", "+ item", "=== ", "3. item", " 2) x"])
def test_a_block_marker_at_the_start_of_a_name_is_escaped(name):
    out = text(name)
    assert "&#" in out and not re.match(r"\s*([#+=-]|\d+[.)])", out)


def test_text_leaves_plain_names_alone():
    assert text("quarter_car rig-2024 (run 3)") == "quarter_car rig-2024 (run 3)"


def test_a_table_cell_cannot_break_the_table():
    table = markdown_table([{"name": NASTY, "value": 1.5}], ["name", "value"])
    lines = table.rstrip("\n").split("\n")
    assert len(lines) == 3  # header, rule, one row
    assert all(line.count("|") == 3 for line in lines)


def test_a_table_of_cell_lists_escapes_like_the_dict_tables():
    lines = table_lines(["name|", "value"], [[NASTY, 1], [True, 2.5]])
    assert len(lines) == 4 and all(line.count("|") == 3 for line in lines)
    assert lines[1] == "|---|---|" and lines[3] == "| True | 2.5 |"  # str of a cell, no fmt
    assert table_lines(["a"], []) == ["| a |", "|---|"]  # no rows: the header alone


def test_a_newline_in_a_recording_name_adds_no_heading_to_the_diagnosis_report(tmp_path):
    from benchmarks.component_truth import make_case
    from suspenv.diagnosis.engine import diagnose, make_family
    from suspenv.reports.diagnosis import write_diagnosis_report

    case = make_case("damper", 7, 0)
    case.recording.name = "front left\n# Verdict: all good"
    diag = diagnose(case.recording, make_family("damper", max_effects=1, screen_families=1))
    write_diagnosis_report(diag, tmp_path)
    report = (tmp_path / "report.md").read_text()
    assert "\n# Verdict" not in report
    assert "front left # Verdict: all good" in report


def test_compare_tables_use_the_same_builder_and_escaping():
    """compare.md's tables (suspenv.analysis.compare) escape a run's text as the reports
    do (suspenv.core.markdown.inline): a line break or ``|`` in a group label cannot break
    the table, and its markup stays text."""
    from suspenv.analysis.compare import _md_table
    from suspenv.core.markdown import inline

    row = {"group": NASTY, "runs": 3, "median": float("inf"), "q25": None}
    table = _md_table([row], ["group", "runs", "median", "q25"])
    lines = table.rstrip("\n").split("\n")
    assert len(lines) == 3 and all(line.count("|") == 5 for line in lines)
    assert lines[2] == f"| {inline(NASTY)} | 3 | inf | – |"
    assert "<b>" not in table and "](" not in table


def test_one_cell_formatter():
    """Reports and compare.md format numbers with the one ``fmt``: 4 significant digits,
    a non-finite number as ``missing``, +inf as ``inf`` only when asked (an ERT that
    never reached its target), booleans as yes/blank."""
    from suspenv.core.markdown import fmt

    assert [fmt(1 / 3), fmt(2.0e-5), fmt(True), fmt(False), fmt(7)] == [
        "0.3333",
        "2e-05",
        "yes",
        "",
        "7",
    ]
    nonfinite = [float("inf"), float("-inf"), float("nan")]
    assert [fmt(v, missing="–") for v in nonfinite] == ["–", "–", "–"]
    assert [fmt(v, missing="–", inf="inf") for v in nonfinite] == ["inf", "–", "–"]
