"""The README's benchmark figures are the rendering of docs/benchmarks/*.json."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from benchmarks import readme

#: what the renderer may import: the standard library's light modules, nothing of suspenv
ALLOWED_IMPORTS = {
    "__future__",
    "argparse",
    "collections.abc",
    "difflib",
    "functools",
    "json",
    "math",
    "pathlib",
    "sys",
    "textwrap",
    "typing",
}


def test_readme_blocks_are_the_rendering_of_the_committed_json() -> None:
    text = readme.README.read_text()
    stale = readme.stale_blocks(text, readme.render(readme.load()))
    assert not stale, (
        "README.md's benchmark figures differ from docs/benchmarks/*.json; run "
        "`python -m benchmarks.readme` (edit benchmarks/templates/readme.txt for wording):\n"
        + "\n".join(stale.values())
    )


def test_document_blocks_are_the_rendering_of_the_committed_json() -> None:
    for doc, blocks in readme.render_documents(readme.load()).items():
        text = (readme.ROOT / doc).read_text()
        stale = readme.stale_blocks(text, blocks, doc)
        assert not stale, f"{doc} is stale; run `python -m benchmarks.readme`"


def _study_json() -> dict:
    summary = {
        "config": "experiments/minibus_nsga2.toml",
        "workers": 2,
        "command_wall_s": 12.04,
        "command_wall_s_slowest": 13.6,
        "loop_wall_s": 7.19,
        "rest_wall_s": 4.85,
        "one_worker_command_wall_s": 15.2,
        "one_worker_loop_wall_s": 11.07,
        "bare_loop_wall_s": 10.77,
        "two_workers_loop_wall_vs_one": 0.6496,
        "cores_free_2proc": 1.976,
        "target_s": 60.0,
        "meets_target": True,
        "same_numbers_1_and_2_workers": True,
        "bare_loop_same_designs": True,
        "other_blas_kernel": {
            "kernel": "Sandybridge",
            "first_different_generation": 5,
            "max_relative_objective_difference_before": 1.36e-14,
            "feasible": 27396,
            "pareto_front": 11343,
        },
        "study": {
            "evaluations": 30000,
            "ok": 30000,
            "feasible": 29033,
            "pareto_front": 7099,
            "objective_names": ["f1_a", "f2_b", "f3_yaw_response_time", "f4_c", "f5_d"],
            "objective_units": ["m/s^2", "m/s^2", "s", "deg", "deg"],
            "baseline_objectives": [1.236, 1.884, -17.80, 143.34, 7.294],
            "ride_focused_pick_objectives": [1.093, 1.682, -17.81, 142.05, 7.013],
            "ride_focused_pick_x": {"K1": 60.257, "T1": 85004.9, "C1": 0.80468},
        },
    }
    return {"summary": summary, "rows": [{"way": "command, 2 workers", "repeats": 3}]}


def test_minibus_study_row_and_paragraph_format_a_hand_made_json() -> None:
    d = _study_json()
    assert readme.minibus_study_cells(d["summary"]) == (
        "12 s for the whole command (7.2 s loop, 4.8 s start-up and report); 1 worker 15 s; "
        "pymoo's bare loop, one process, 11 s",
        "<= 60 s (met)",
    )
    text = " ".join(readme.minibus_study_paragraph(d).split())
    assert "runs 30,000 evaluations in **7.2 s of loop wall time**, 12 s for the whole" in text
    assert "the median of 3 runs, the slowest 14 s), inside the 60 s goal" in text
    # 11.07 / 10.77 = 1.028; 1 - 0.6496 = 35 %
    assert "takes 1.03x the bare loop's time in one process, and the pool of 2 takes 35 %" in text
    assert "29,033 were feasible, 7,099 on the Pareto front" in text
    assert "(`OPENBLAS_CORETYPE=Sandybridge`) the objectives differ by up to 1e-14" in text
    assert "flips in generation 5 and the run ends with 27,396 feasible, 11,343" in text
    assert "lowered f1 from 1.236 to 1.093 m/s² and f2 from 1.884 to 1.682 m/s²" in text
    assert "(f3 -17.8 against -17.8 s, f4 142 against 143 deg, f5 7.01 against 7.29 deg" in text
    assert text.endswith("K1 60.3, T1 8.5e4, C1 0.805).")
    assert max(len(line) for line in readme.minibus_study_paragraph(d).splitlines()) <= 88


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("ride_focused_pick_objectives", [1.0, 1.5, -17.0, 142.0, 7.0], "f3, f4 and f5"),
        ("same_numbers_1_and_2_workers", False, "workers"),
        ("bare_loop_same_designs", False, "bare loop"),
    ],
)
def test_minibus_study_words_the_json_contradicts_stop_the_rendering(key, value, match) -> None:
    d = _study_json()
    if key in d["summary"]["study"]:
        d["summary"]["study"][key] = value
    else:
        d["summary"][key] = value
    with pytest.raises(readme.FigureError, match=match):
        readme.minibus_study_paragraph(d)


def test_ride_noise_cells_format_a_hand_made_summary() -> None:
    summary = {
        "default_method": "spectral",
        "spectral_max_cv_percent": 4.0182413126450673e-14,
        "time_max_cv_percent": 9.773336258538148,
        "target_cv_percent": 1.0,
        "default_meets_target": True,
    }
    assert readme.ride_noise_cells(summary) == (
        "largest scatter of any ride objective 4e-14 % with the exact spectral integral (the "
        "default); 9.8 % with a 10 s time-domain record",
        "<= 1 % (met)",
    )
    with pytest.raises(readme.FigureError, match="spectral"):
        readme.ride_noise_cells(summary | {"default_method": "time"})


def test_knc_speed_cells_format_a_hand_made_summary() -> None:
    # every target of issue 17 stated from the summary's own flags
    summary = {
        "ms_per_candidate_batched": 6.647676571428571,
        "ms_per_candidate_single": 23.4,
        "ms_per_candidate_batch_1000": 7.1,
        "meets_stretch": False,
        "meets_single_target_10ms": False,
        "meets_no_rise_to_batch_1000": True,
        "meets_memory_target_at_batch": {"1": False, "8": False, "42": True, "1000": True},
        "peak_mb_per_candidate": {"1": 0.171, "8": 0.1634, "42": 0.0844, "1000": 0.0057},
        "worst_peak_mb_per_candidate": 0.171,
        "worst_memory_batch": 1,
        "speedup_vs_paper_20s": 3008.56995449495,
        "target_mb_per_candidate": 0.1,
        "python_sweep_ms_per_candidate": {"1": 30.0, "42": 8.0, "1000": 9.0},
        "compiled_sweep_ms_per_candidate": {"1": 25.0, "42": 7.0, "1000": 7.5},
        "compiled_targets_ms": {"1": 1.0, "42": 0.3},
        "meets_compiled_single_target": False,
        "meets_compiled_batch_target": True,
        "processes": 5,
        "load_average_1min": 0.44,
    }
    assert readme.knc_speed_cells(summary) == (
        "6.65 ms CPU per candidate at batch 42 (about 3000x the paper's 20 s), 23.4 ms one "
        "at a time (both medians of 5 fresh processes, load average 0.4), 7.10 ms at "
        "batch 1000 (in the same run, the objectives in numpy after "
        "the compiled sweep: 7.00, 25.0 and 7.50 ms; the sweep driven from Python: "
        "8.00, 30.0 and 9.00 ms); peak 0.084 MB per candidate at batch 42 (the compiled "
        "loops' scratch counted), 0.17 MB one at a time, 0.171 MB at most over the batch "
        "sizes (batch 1, of 4 batch sizes from 1 to 1000)",
        "<= 2 ms at batch 42 (not met), <= 10 ms one at a time (not met), compiled evaluation "
        "<= 0.3 ms at batch 42 (met) and <= 1 ms one at a time (not met), <= 0.1 MB per "
        "candidate (met at batch 42, 1000; not at batch 1, 8), no rise to batch 1000 (met)",
    )
    faster = summary | {"ms_per_candidate_batched": 1.94, "meets_stretch": True}
    faster["speedup_vs_paper_20s"] = 20_000 / 1.94
    faster["meets_memory_target_at_batch"] = {"1": True, "8": True, "42": True, "1000": True}
    result, target = readme.knc_speed_cells(faster)
    assert result.startswith("1.94 ms CPU per candidate at batch 42 (about 10000x the paper")
    assert target.startswith("<= 2 ms at batch 42 (met)")
    assert "<= 0.1 MB per candidate (met at every batch size)" in target
    # one at a time candidate by candidate: counted, and a miss stated
    alone = {"candidates": 200, "median_mb": 0.0991, "max_mb": 0.316, "within_target": 190}
    result, target = readme.knc_speed_cells(faster | {"memory_one_at_a_time": alone})
    assert "0.099 MB one at a time (median of 200 candidates, 190 within 0.1 MB, at most " in result
    assert "(met at every batch size; one at a time not for 10 of 200 candidates)" in target
    every = alone | {"within_target": 200, "max_mb": 0.099}
    _, target = readme.knc_speed_cells(faster | {"memory_one_at_a_time": every})
    assert "(met at every batch size; met for every candidate one at a time)" in target


def test_knc_speed_tables_format_a_hand_made_json() -> None:
    # docs/knc.md's block: both paths at batch 1, 42 and 1000, the sweep, the candidates
    rows = [
        {"path": p, "batch": b, "cpu_ms_per_candidate": ms, "peak_mb_per_candidate": mb}
        for p, b, ms, mb in (
            ("baseline", 1, 22.43, 0.6341),
            ("python_sweep", 1, 5.5, 0.1),
            ("compiled_sweep", 1, 4.25, 0.1),
            ("optimised", 1, 3.775, 0.10947),
            ("baseline", 42, 2.0999, 0.5512),
            ("python_sweep", 42, 0.9, 0.05),
            ("compiled_sweep", 42, 0.7, 0.05),
            ("optimised", 42, 0.5579, 0.050906),
            ("baseline", 1000, 2.888, 0.5499),
            ("python_sweep", 1000, 0.8, 0.004),
            ("compiled_sweep", 1000, 0.6, 0.004),
            ("optimised", 1000, 0.5118, 0.0036115),
        )
    ]
    alone = {
        "candidates": 200,
        "median_mb": 0.0991,
        "max_mb": 0.3162,
        "within_target": 190,
    }
    summary = {
        "peak_mb_per_candidate": {"1": 0.1004, "2": 0.0946},
        "memory_one_at_a_time": alone,
        "target_mb_per_candidate": 0.1,
    }
    text = readme.knc_speed_tables({"rows": rows, "summary": summary})
    assert text.splitlines()[:9] == [
        "| mode | CPU ms / candidate | numpy objectives (same run) | sweep from Python (same "
        "run) | baseline (same run) | peak MB / candidate | baseline peak MB |",
        "|---|---|---|---|---|---|---|",
        "| one at a time | 3.77 | 4.25 | 5.50 | 22.4 | 0.109 | 0.63 |",
        "| batch of 42 | 0.56 | 0.70 | 0.90 | 2.1 | 0.0509 | 0.55 |",
        "| batch of 1000 | 0.51 | 0.60 | 0.80 | 2.89 | 0.00361 | 0.55 |",
        "",
        "| batch | 1 | 2 |",
        "|---|---|---|",
        "| peak MB / candidate | 0.100 | 0.0946 |",
    ]
    assert " ".join(text.splitlines()[10:]) == (
        "One at a time, candidate by candidate (200 random designs): median 0.099 MB, at "
        "most 0.316 MB; 190 of 200 within 0.1 MB."
    )


@pytest.mark.parametrize(
    ("value", "text"), [(1.199, "1.2"), (9.94, "9.9"), (9.96, "10"), (15.98, "16"), (178.9, "179")]
)
def test_seconds_keep_two_figures_below_ten_and_whole_seconds_above(
    value: float, text: str
) -> None:
    assert readme.seconds(value) == text


def test_percent_count_and_order_formats() -> None:
    assert readme.percent(-0.886277296833812) == "-89 %"
    assert readme.percent(0.019089179714137587, 1) == "1.9 %"
    assert readme.percent(0.0073459221049534396, 1, sign=True) == "+0.7 %"
    assert readme.count(1.0 * 24, 24) == "24 / 24"
    assert readme.count_text("0/20") == "0 / 20"
    assert readme.order_of(6.071853897602088e-10) == "1e-9"
    assert readme.span(34.7, 62.2) == "35-62"


def test_write_block_replaces_only_between_the_markers(tmp_path: Path) -> None:
    begin, end = readme.markers("performance")
    text = f"intro\n\n{begin}\n| old |\n{end}\n\nafter\n"
    new = readme.write_block(text, "performance", "| new |")
    assert new == f"intro\n\n{begin}\n| new |\n{end}\n\nafter\n"
    assert readme.read_block(new, "performance") == "| new |"
    with pytest.raises(readme.FigureError):
        readme.read_block("no markers", "performance")


def test_check_exits_1_on_a_stale_readme_and_0_after_the_rewrite(tmp_path: Path) -> None:
    stale = readme.README.read_text().replace("| what | command | result | target |", "| x |")
    path = tmp_path / "README.md"
    path.write_text(stale)
    argv = ["--readme", str(path), "--bench-dir", str(readme.BENCH_DIR)]
    assert readme.main([*argv, "--check"]) == 1
    assert path.read_text() == stale
    assert readme.main(argv) == 0
    assert readme.main([*argv, "--check"]) == 0


def test_a_benchmark_rerun_that_changes_a_number_makes_the_readme_stale(tmp_path: Path) -> None:
    for name in (n for names in readme.SOURCES.values() for n in names):
        (tmp_path / f"{name}.json").write_text((readme.BENCH_DIR / f"{name}.json").read_text())
    rerun = json.loads((tmp_path / "knc_speed.json").read_text())
    rerun["summary"]["ms_per_candidate_batched"] = 7.04
    rerun["summary"]["speedup_vs_paper_20s"] = 20_000 / 7.04
    (tmp_path / "knc_speed.json").write_text(json.dumps(rerun))
    argv = ["--readme", str(readme.README), "--bench-dir", str(tmp_path), "--check"]
    assert readme.main(argv) == 1
    table = readme.render(readme.load(tmp_path))["performance"]
    about = readme.significant(20_000 / 7.04)
    assert f"| 7.04 ms CPU per candidate at batch 42 (about {about}x" in table


def test_wording_that_the_json_contradicts_stops_the_rendering() -> None:
    data = dict(readme.load())
    bench = dict(data["diagnosis_benchmark"])
    bench["per_family"] = {"damper": {}}
    data["diagnosis_benchmark"] = bench
    with pytest.raises(readme.FigureError, match="families"):
        readme.render(data)


def test_the_renderer_imports_only_light_standard_modules() -> None:
    tree = ast.parse(Path(readme.__file__).read_text())
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert imported <= ALLOWED_IMPORTS, imported - ALLOWED_IMPORTS


def test_identify_reference_block_formats_a_hand_made_json() -> None:
    # docs/identify.md's block: who won, one table row per case, the noise-only errors
    def row(case, seed, answer, identified, err, named):
        return {
            "case": case,
            "seed": seed,
            "curves_within_1.5": "33/33",
            "worst_rms_over_noise": 1.104,
            "answer": f"polish from the {answer}",
            "identified": identified,
            "determined_combinations": 14,
            "identified_max_err_%": err,
            "all_mean_err_%": 20.06,
            "next_test": "steering",
            "named": named,
            "wall_s": 9.6,
            "cpu_s": 10.4,
            "rerun_identified": 3,
        }

    rows = [
        row("noise only", 0, "start design", 3, 0.1688, "none"),
        row("default concealed", 1, "CMA-ES best", 0, float("nan"), "progressive,loop"),
    ]
    text = readme.identify_reference_block({"rows": rows})
    lines = text.splitlines()
    assert " ".join(lines[:2]) == (
        '"answer": which polish had the lower cost. The global stage\'s valley won on 1 of '
        "the 2 cases (default concealed seed 1); on the others the polish from the start did."
    )
    assert lines[5] == (
        "| noise only | 0 | 33 / 33 | 1.10 | start design | 3 | 14 | 0.17 | 20.1 | steering "
        "| 3 | nothing | 10 / 10 |"
    )
    assert lines[6] == (
        "| default concealed | 1 | 33 / 33 | 1.10 | CMA-ES best | 0 | 14 | - | 20.1 | "
        "steering | 3 | cubic, loop | 10 / 10 |"
    )
    assert " ".join(lines[8:]) == (
        "With noise only, 3 parameters are identified on each seed, the worst of them "
        "within 0.17 % of its range; all 49 have a mean error of 20 % of the range."
    )
    with pytest.raises(readme.FigureError, match="answer"):
        readme.identify_reference_block({"rows": [row("noise only", 0, "moon", 3, 0.1, "none")]})


def _overhead_json() -> dict:
    loops = []
    for lib, bare_ms, lean, full in (
        ("pycma", 0.0352, 0.98, 1.153),
        ("pymoo", 0.0311, 1.056, 1.198),
        ("optuna", 0.503, 1.193, 1.195),
    ):
        loops += [
            {"library": lib, "case": "bare", "ms_per_eval": bare_ms, "ratio_vs_bare": 1.0},
            {"library": lib, "case": "suspenv, no archive", "ratio_vs_bare": lean},
            {"library": lib, "case": "suspenv + archive", "ratio_vs_bare": full},
        ]
    for r in loops:
        r["ratio_of_best"] = r["ratio_vs_bare"]
    workers = []
    # K&C: 4 batches of 42; 100 ms CPU in-process (25 ms a batch, 23 ms of it the problem)
    for w, chunk, cpu, wall in ((1, "default", 0.100, 0.100), (2, "default", 0.150, 0.11)):
        workers.append((w, chunk, cpu, wall))
    workers += [(2, "5", 0.27, 0.18), (2, "1", 0.79, 0.48)]
    for w, chunk, cpu, wall in workers:
        for case in readme.WORKER_PROBLEMS:
            loops.append(
                {
                    "library": "workers",
                    "case": f"{case}: workers={w}, chunk={chunk}",
                    "evaluations": 168,
                    "batch": 42,
                    "cpu_s": cpu,
                    "cpu_vs_workers_1": cpu / 0.100,
                    "wall_vs_workers_1": wall / 0.100,
                    "evaluation_ms_per_batch": 23.0,
                    "cores_free_2proc": 1.97,
                }
            )
    return {"rows": loops}


def test_overhead_tables_format_a_hand_made_json() -> None:
    # docs/runs.md's blocks: the loops against the bare libraries; the workers study with
    # k = (0.79 - 0.15) s / (4 batches x 40 extra chunks) = 4 ms and the prediction
    # rest + k + e / 2 = 2 + 4 + 23 / 2 = 17.5 ms against 25 ms in-process
    d = _overhead_json()
    loops = readme.overhead_loop_table(d).splitlines()
    assert loops[2] == (
        "| pycma `ask`/`tell`, 49-D sphere, population 42 | 0.035 | 0.98x; 0.98x | "
        "**1.15x**; 1.15x |"
    )
    block = readme.overhead_workers_block(d).splitlines()
    assert block[3] == (
        "| K&C identification | 25 ms (23 ms) | 4.0 ms | 1.50x | 1.10x (4 batches) | "
        "2.0 + 4.0 + 23 / 2 = 18 ms per batch: 1.4x faster |"
    )
    summary = {
        "framework_overhead_ms_per_eval": 0.0049,
        "ratio_vs_bare_pycma": 1.153,
        "ratio_vs_bare_pymoo": 1.198,
        "ratio_vs_bare_optuna": 1.195,
        "repeat": 21,
        "target_overhead_ms_per_eval": 0.2,
        "target_ratio": 1.2,
        "meets_targets": True,
    }
    assert readme.overhead_cells(summary) == (
        "0.005 ms over bare pycma; with the archive 1.15x bare pycma, 1.20x bare pymoo, "
        "1.20x optuna's batched loop (medians of 21)",
        "<= 0.2 ms, <= 1.2x each (met)",
    )


def test_knc_diagnosis_tables_format_a_hand_made_json() -> None:
    # docs/diagnosis_knc.md's tables: scores counted from the rows, the per-seed words
    def row(seed, case_type, truth, named, snr, detectable, where, where_ok, ambiguous, err):
        n_true = 0 if truth == "none" else len(truth.split(","))
        return {
            "seed": seed,
            "case_type": case_type,
            "truth": truth,
            "named": named,
            "n_true": n_true,
            "snr": snr,
            "detectable": detectable,
            "top1_ok": named.split(",")[0] in truth.split(","),
            "all_found": set(truth.split(",")) <= set(named.split(",")),
            "false_alarms": int(truth == "none" and named != "none"),
            "hysteresis_where": where,
            "where_ok": where_ok,
            "where_ok_or_ambiguous": ambiguous,
            "heldout_ratio": 1.0 if named == "none" else 0.8274,
            "model_error_ratio": 1.0 if named == "none" else 0.2118,
            "param_rel_err": err,
            "noise_scale": 1.406,
            "seconds": 13.6,
            "cpu_seconds": 9.3,
        }

    rows = [
        row(1000, "hysteresis@all", "dahl_hysteresis", "dahl_hysteresis", "73.7", True,
            "dahl_hysteresis@lower_arm", False, True, 0.006),
        row(1001, "asymmetry", "lr_asymmetry", "lr_asymmetry,sensor_gain", "4.7", False,
            "", None, None, 0.0254),
        row(1003, "none", "none", "none", "", False, "", None, None, float("nan")),
    ]  # fmt: skip
    summary = {
        "top1_accuracy_one_effect": 1.0,
        "top1_accuracy_one_effect_detectable": 1.0,
        "extra_kinds_named_per_effect_case": 0.5,
        "hysteresis_location_correct": 0.0,
        "median_heldout_ratio_effect_cases": 0.8274,
        "median_model_error_ratio_effect_cases": 0.2118,
        "median_model_error_ratio_detectable_effect_cases": 0.1869,
        "median_excess_ratio_effect_cases": 0.2913,
        "median_param_rel_err": 0.0157,
        "median_seconds_per_diagnosis": 12.3,
        "max_seconds_per_diagnosis": 65.2,
        "median_cpu_seconds_per_diagnosis": 8.4,
        "max_cpu_seconds_per_diagnosis": 43.6,
        "top1_by_case_type": {"asymmetry": "1/1", "hysteresis@all": "1/1"},
    }
    lines = readme.knc_diagnosis_tables({"rows": rows, "summary": summary}).splitlines()
    assert "| top-1 naming, one-effect cases, all | 2 / 2 (1.00) | >= 0.90 |" in lines
    assert "| false alarms, no-effect cases | 0 / 1 | <= 0.10 |" in lines
    assert "| extra (untrue) kinds named per effect case | 0.50 (1 in 2) | |" in lines
    assert "| wall time per diagnosis, median / max | 12 s / 65 s | < 300 s |" in lines
    assert (
        "Top-1 naming by single-effect type: every type 1 / 1 (asymmetry, hysteresis @ all)."
        in lines
    )
    assert lines[-3:] == [
        "| 1000 | hysteresis @ all, noise x1.41 | 73.7 | hysteresis (lower arm), true location "
        "stated not separable | 0.83 / 0.21 | 0.6 % | 14 / 9 |",
        "| 1001 | asymmetry, noise x1.41 | 4.7 (< 5) | L/R asymmetry + sensor gain | 0.83 / "
        "0.21 | 2.5 % | 14 / 9 |",
        "| 1003 | none, noise x1.41 | - | none | 1 / 1 |  | 14 / 9 |",
    ]


def test_tey_pipeline_paragraph_formats_a_hand_made_json() -> None:
    # docs/tey2014.md's sentence: the totals, their ratio and the slowest step (not the
    # total or the baseline rows)
    d = {
        "summary": {
            "evaluations": 2726,
            "pipeline_wall_s": 5.34,
            "bare_evaluation_s": 1.68,
            "pipeline_over_bare_evaluation": 3.19,
            "target_s": 120.0,
            "within_target": True,
            "workers": 1,
        },
        "rows": [
            {"step": "optimisation", "seconds": 2.04},
            {"step": "report", "seconds": 2.51},
            {"step": "total (pipeline)", "seconds": 5.34},
            {"step": "baseline: bare evaluation of 2726 designs", "seconds": 1.68},
        ],
    }
    assert " ".join(readme.tey_pipeline_paragraph(d).splitlines()) == (
        "The run recorded in the JSON (in-process): 5.3 s for 2,726 evaluations, against "
        "1.7 s for the bare batch evaluation of as many designs (3.2x; the rest: the "
        "analysis, the identifiability profiles and the report; the slowest step: report, "
        "2.5 s); within the target of 120 s."
    )


def test_minibus_paper_table_formats_a_hand_made_json() -> None:
    names = ("baseline", "pick")
    figures = {
        f"{stem}_{lc}": [0.5, 0.25]
        for lc in ("no_load", "full_load")
        for stem, *_ in readme.PAPER_FIGURES
    }
    block = {"names": ["f1"], "units": ["s"], "values": {n: [1.23456] for n in names}}
    table = {
        "designs": {n: [60.0, 130.0, 1000.0, 7e4, 2e5, 2e5, 0.6, 0.6] for n in names},
        "default": block,
        "study": block,
        "figures": figures,
    }
    text = readme.minibus_paper_table({"summary": {"paper_table": table}})
    lines = text.splitlines()
    assert lines[0] == "| | baseline | pick |"
    assert "| T1 | 7.0e4 | 7.0e4 |" in lines
    assert "| f1 [s], default set | 1.235 | 1.235 |" in lines
    assert "| front share of roll stiffness (%), full load | 50.0 | 25.0 |" in lines
    assert "| front/rear frequency ratio, no load | 0.500 | 0.250 |" in lines


def test_component_condition_rows_format_a_hand_made_json() -> None:
    summary = {
        "n_cases": 20,
        "single_top1_family": 0.95,
        "control_false_alarm": 0.05,
        "median_seconds": 3.21,
        "median_cpu_seconds": 1.04,
    }
    d = {"conditions": {"masses_undeclared": {"all": summary}}}
    assert readme.component_condition_rows(d) == [
        "| components, quarter-car masses not declared (20 cases, seeds fixed before the "
        "run) | 95 % (target >= 95 %) | 5 % (target <= 5 %) | | | 3.2 s median wall (1.0 s "
        "CPU) |"
    ]
    assert readme.component_condition_rows({}) == []
