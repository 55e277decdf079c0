"""The README's benchmark figures, rendered from the JSON the benchmark scripts write.

Three blocks are generated, each between marker comments:

- ``performance`` (README.md): the table of the "Performance" section (``overhead.json``,
  ``knc_speed.json``, ``identify_reference.json``, ``tey2014_pipeline.json``,
  ``minibus_speed.json``, ``ride_noise.json``, ``minibus_study.json``,
  ``planar_speed.json``, ``first_run.json``);
- ``diagnosis`` (README.md): the blind-benchmark table, the "Real recordings" paragraph
  and the real-recordings table under "A diagnosis, on real recordings"
  (``diagnosis_benchmark.json``, ``independent_diagnosis.json``, ``real_recordings.json``,
  ``knc_diagnosis.json``, ``ride_diagnosis.json``);
- ``minibus-study`` (docs/minibus_handling.md): "The study's run, measured"
  (``minibus_study.json``);
- ``minibus-paper`` (docs/minibus.md): the study's table side by side
  (``minibus_objectives.json``).

Only the numbers come from the JSON; the wording, columns and targets are the templates
of ``benchmarks/templates/readme.txt`` (Python format fields, filled by :func:`fill`).
Figures no JSON holds stay static text there: the K&C stretch target, 2 ms
(``STRETCH_MS`` in knc_speed.py); the component targets (docs/diagnosis.md); the
concealed road waviness, w = 2.5; the dyno's drift inside each speed, 0.2-1.3 N/s
(docs/diagnosis.md). Where the wording states a verdict (a target met, an effect named)
the rendering checks the JSON still says so and stops with :class:`FigureError` otherwise,
so the words cannot go stale either.

Run: ``python -m benchmarks.readme`` rewrites the blocks in place and prints what
changed; ``python -m benchmarks.readme --check`` exits 1 when a file differs from the
rendering. Standard library only: no model, no numpy, no matplotlib.
"""

from __future__ import annotations

import argparse
import difflib
import json
import math
import sys
import textwrap
from collections.abc import Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import Any

#: repository root (this file is benchmarks/readme.py)
ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BENCH_DIR = ROOT / "docs" / "benchmarks"
#: the blocks' wording (format templates, one [section] per text)
TEMPLATES = Path(__file__).resolve().parent / "templates" / "readme.txt"

#: the JSON files the blocks read, by file stem
SOURCES: dict[str, tuple[str, ...]] = {
    "performance": (
        "overhead",
        "knc_speed",
        "identify_reference",
        "tey2014_pipeline",
        "minibus_speed",
        "ride_noise",
        "minibus_study",
        "planar_speed",
        "first_run",
    ),
    "documents": ("minibus_objectives", "minibus_ride_effects", "minibus_stop_criteria"),
    "diagnosis": (
        "diagnosis_benchmark",
        "independent_diagnosis",
        "real_recordings",
        "knc_diagnosis",
        "knc_outside",
        "ride_diagnosis",
    ),
}

#: documents other than README.md with generated blocks (path relative to the repository)
DOCUMENT_BLOCKS: dict[str, tuple[str, ...]] = {
    "docs/minibus_handling.md": ("minibus-study",),
    "docs/minibus.md": ("minibus-paper", "minibus-effects", "minibus-stops"),
    "docs/knc.md": ("knc-speed",),
    "docs/identify.md": ("identify-reference",),
    "docs/runs.md": ("overhead-loops", "overhead-workers"),
    "docs/diagnosis_knc.md": ("knc-diagnosis",),
    "docs/tey2014.md": ("tey-pipeline",),
}

Json = Mapping[str, Any]


class FigureError(ValueError):
    """The JSON no longer supports the README's fixed wording (edit templates/readme.txt)."""


#: the guide's words for the elements the engine may name after EMPS's friction
#: (``FrictionGuideModel.device_words``; this module imports no model)
GUIDE_WORDS = {"damper_asymmetry": "direction-dependent viscous friction"}


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise FigureError(message)


@cache
def _templates() -> dict[str, str]:
    """The [sections] of templates/readme.txt: each one line of text, its lines joined
    with spaces, or (``[name/lines]``) its lines as they are."""
    sections: dict[str, list[str]] = {}
    lines: list[str] = []
    for line in TEMPLATES.read_text(encoding="utf-8").splitlines():
        if line.startswith("[") and line.endswith("]"):
            lines = sections.setdefault(line[1:-1], [])
        elif line.strip() and not line.startswith("#"):
            lines.append(line.strip())
    return {
        name.removesuffix("/lines"): ("\n" if name.endswith("/lines") else " ").join(lines)
        for name, lines in sections.items()
    }


def fill(section: str, **values: Any) -> str:
    """The template ``section`` with its format fields filled from ``values``."""
    return _templates()[section].format_map(values)


# ------------------------------------------------------------------ number formats
def seconds(s: float) -> str:
    """``"1.2"``, ``"9.9"``, ``"16"``, ``"179"``: one decimal below 10 s, whole seconds above."""
    return f"{s:.1f}" if round(s, 1) < 10 else f"{s:.0f}"


def percent(fraction: float, decimals: int = 0, sign: bool = False) -> str:
    """``0.886 -> "89 %"``; ``sign`` gives ``"+7.8 %"``; a reduction is passed negated."""
    return f"{100 * fraction:{'+' if sign else ''}.{decimals}f} %"


def count(k: float, n: float) -> str:
    """``"24 / 24"`` (``k`` may be a rate times ``n``, rounded)."""
    return f"{round(k)} / {round(n)}"


def count_text(k_of_n: str) -> str:
    """``"0/2" -> "0 / 2"`` (the ride benchmark stores its counts as text)."""
    k, n = k_of_n.split("/")
    return f"{int(k)} / {int(n)}"


def paragraph(text: str) -> str:
    """``text`` wrapped at 88 columns, as the documents' paragraphs are (no word split)."""
    return textwrap.fill(text, width=88, break_long_words=False, break_on_hyphens=False)


def significant(x: float, digits: int = 2) -> str:
    """``3008.6 -> "3000"``: ``x`` rounded to ``digits`` significant figures."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    places = digits - 1 - math.floor(math.log10(abs(x)))
    return f"{round(x, places):.{max(places, 0)}f}"


def span(lo: float, hi: float) -> str:
    """``"35-62"``: whole numbers, one number when both round alike."""
    a, b = f"{lo:.0f}", f"{hi:.0f}"
    return a if a == b else f"{a}-{b}"


def order_of(p: float) -> str:
    """``6.1e-10 -> "1e-9"``: the nearest power of ten."""
    return f"1e{round(math.log10(p))}"


# ------------------------------------------------------------------ performance
def met(flag: bool) -> str:
    """A target's state in a table cell."""
    return "met" if flag else "not met"


def overhead_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the framework-overhead row from ``overhead.json``'s summary."""
    return fill("overhead.result", s=s), fill("overhead.target", s=s, met=met(s["meets_targets"]))


def knc_speed_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the K&C evaluation row from ``knc_speed.json``'s summary
    (issue 17's targets: 2 ms at batch 42, 10 ms one at a time, 0.1 MB per candidate at
    every batch size of the memory sweep, no rise of the per-candidate time up to batch 1000)."""
    mb = s["peak_mb_per_candidate"]
    py = s["python_sweep_ms_per_candidate"]
    cs = s["compiled_sweep_ms_per_candidate"]
    limit = s["target_mb_per_candidate"]
    alone = s.get("memory_one_at_a_time")
    one = (
        f"{mb['1']:.2f} MB one at a time"
        if alone is None
        else fill("knc_speed.one", alone=alone, limit=limit)
    )
    result = fill(
        "knc_speed.result", s=s, mb42=mb["42"], one=one, py42=py["42"], py1=py["1"],
        py1000=py["1000"], cs42=cs["42"], cs1=cs["1"], cs1000=cs["1000"],
        paper=significant(s["speedup_vs_paper_20s"]), n_batches=len(mb),
        lo=min(map(int, mb)), hi=max(map(int, mb)),
    )  # fmt: skip

    per_batch = s["meets_memory_target_at_batch"]
    memory = (
        "met at every batch size"
        if all(per_batch.values())
        else "met at batch "
        + ", ".join(b for b, ok in per_batch.items() if ok)
        + "; not at batch "
        + ", ".join(b for b, ok in per_batch.items() if not ok)
    )
    if alone is not None:
        left = alone["candidates"] - alone["within_target"]
        memory += (
            "; met for every candidate one at a time"
            if left == 0
            else f"; one at a time not for {left} of {alone['candidates']} candidates"
        )
    target = fill(
        "knc_speed.target", stretch=met(s["meets_stretch"]), limit=limit, memory=memory,
        single=met(s["meets_single_target_10ms"]), rise=met(s["meets_no_rise_to_batch_1000"]),
        c42=met(s["meets_compiled_batch_target"]), c1=met(s["meets_compiled_single_target"]),
        t42=s["compiled_targets_ms"]["42"], t1=s["compiled_targets_ms"]["1"],
    )  # fmt: skip
    return result, target


def tey_pipeline_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the Tey et al. pipeline row from ``tey2014_pipeline.json``."""
    return fill("tey.result", wall=float(s["pipeline_wall_s"])), fill("tey.target", s=s)


def identify_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the whole-curve identification row from
    ``identify_reference.json`` (issue targets: every curve within 1.5 x its noise,
    identified parameters within 2 % of their range, <= 2 min on 2 cores)."""
    curves = "every curve" if s["noise_only_every_curve_within_1.5"] else "NOT every curve"
    keys = ("noise_only_identified_max_err_%", "max_wall_s", "max_cpu_s")
    err, wall, cpu = (float(s[k]) for k in keys)
    result = fill("identify.result", curves=curves, err=err, wall=wall, cpu=cpu)
    target = fill("identify.target")
    if "main_curves_after" in s:  # the main job's loop, held-out test and sheet
        result += fill(
            "identify.loop", s=s, before=count_text(s["main_curves_before"]),
            after=count_text(s["main_curves_after"]),
            test_car=100 * float(s["test_car_sheet_coverage"]),
            blind=100 * float(s.get("blind_sheet_coverage", float("nan"))),
        )  # fmt: skip
        target += fill("identify.loop_target")
    if "steering_car" in s:
        result += fill("identify.steering", err=s["steering_car"]["aligning_compliance_err_%"])
        target += fill("identify.steering_target")
    return result, target


def minibus_speed_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the minibus evaluation row from ``minibus_speed.json``."""
    flags = {
        "batched": met(s["meets_batched_target"]),
        "single": met(s["meets_single_target"]),
        "compiled": met(s["meets_single_compiled_target"]),
    }
    return fill("minibus_speed.result", s=s), fill("minibus_speed.target", s=s, **flags)


def ride_noise_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the ride objectives' noise row from ``ride_noise.json``."""
    _require(s["default_method"] == "spectral", "the default ride method is no longer spectral")
    met_ = met(s["default_meets_target"])
    return fill("ride_noise.result", s=s), fill("ride_noise.target", s=s, met=met_)


def minibus_study_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the minibus study's row from ``minibus_study.json``."""
    times = {k: seconds(s[f"{k}_wall_s"]) for k in ("command", "loop", "rest", "bare_loop")}
    result = fill(
        "minibus_study.result", command=times["command"], loop=times["loop"],
        rest=times["rest"], one=seconds(s["one_worker_command_wall_s"]), bare=times["bare_loop"],
    )  # fmt: skip
    if s["cores_free_2proc"] < 1.5:  # a loaded machine: the wall time is not the code's
        result += " " + fill("minibus_study.load", s=s, cpu=seconds(s["command_cpu_s"]))
    return result, fill("minibus_study.target", s=s, met=met(s["meets_target"]))


def short(x: float) -> str:
    """``85004.9 -> "8.5e4"``, ``1522.4 -> "1520"``, ``0.8047 -> "0.805"``: a design
    variable in a sentence."""
    if abs(x) >= 1e4:
        mantissa, exponent = f"{x:.1e}".split("e")
        return f"{mantissa}e{int(exponent)}"
    return significant(x, 3)


def _kernel_path(s: Json) -> str:
    """How the study's path went under the other BLAS kernel (``minibus_study.json``)."""
    k = s["other_blas_kernel"]
    if k["first_different_generation"] is None:
        return "no selection tie flips and the run ends with the same counts"
    return (
        f"a selection tie flips in generation {k['first_different_generation']} and the run "
        f"ends with {k['feasible']:,} feasible, {k['pareto_front']:,} on the front"
    )


def minibus_study_paragraph(d: Json) -> str:
    """docs/minibus_handling.md's "The study's run, measured" from ``minibus_study.json``."""
    s = d["summary"]
    st = s["study"]
    base, pick = st["baseline_objectives"], st["ride_focused_pick_objectives"]
    _require(
        all(p <= b + 1e-12 for p, b in zip(pick[2:5], base[2:5], strict=True)),
        "the ride-focused pick no longer keeps f3, f4 and f5 at the baseline's",
    )
    _require(s["same_numbers_1_and_2_workers"], "1 and 2 workers archived different numbers")
    _require(s["bare_loop_same_designs"], "the bare loop no longer evaluates the run's designs")
    repeats = {r["way"]: r for r in d["rows"]}["command, 2 workers"]["repeats"]
    names, units = st["objective_names"], st["objective_units"]
    no_worse = ", ".join(
        f"{names[i].split('_')[0]} {pick[i]:.3g} against {base[i]:.3g} {units[i]}"
        for i in (2, 3, 4)
    )
    text = fill(
        "minibus_study.paragraph", s=s, st=st, base=base, pick=pick,
        loop=seconds(s["loop_wall_s"]), command=seconds(s["command_wall_s"]),
        rest=seconds(s["rest_wall_s"]), slowest=seconds(s["command_wall_s_slowest"]),
        of_runs="one run" if repeats == 1 else f"the median of {repeats} runs",
        inside="inside" if s["meets_target"] else "outside",
        one=seconds(s["one_worker_loop_wall_s"]), bare=seconds(s["bare_loop_wall_s"]),
        one_over_bare=s["one_worker_loop_wall_s"] / s["bare_loop_wall_s"],
        pool_gain=percent(1.0 - s["two_workers_loop_wall_vs_one"]),
        variables=", ".join(f"{k} {short(v)}" for k, v in st["ride_focused_pick_x"].items()),
        k=s["other_blas_kernel"], no_worse=no_worse, kernel_path=_kernel_path(s),
    )  # fmt: skip
    return paragraph(text)


#: routine figures of docs/minibus.md's side-by-side table: key stem, label, factor, digits
PAPER_FIGURES = (
    ("freq_front", "front natural frequency (Hz)", 1.0, 2),
    ("freq_rear", "rear natural frequency (Hz)", 1.0, 2),
    ("freq_ratio", "front/rear frequency ratio", 1.0, 3),
    ("zeta_front", "front damping ratio", 1.0, 3),
    ("zeta_rear", "rear damping ratio", 1.0, 3),
    ("roll_share_front", "front share of roll stiffness (%)", 100.0, 1),
)


def minibus_paper_table(d: Json) -> str:
    """docs/minibus.md's side-by-side table (``minibus_objectives.json``'s
    ``paper_table``): designs, both objective sets and the routine figures."""
    t = d["summary"]["paper_table"]
    names = list(t["designs"])
    lines = ["| | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    variables = ("K1", "K2", "K3", "T1", "T2", "T3", "C1", "C2")
    for j, var in enumerate(variables):
        lines.append(f"| {var} | " + " | ".join(short(t["designs"][n][j]) for n in names) + " |")
    for label, key in (("default set", "default"), ("study's set", "study")):
        block = t[key]
        for j, (obj, unit) in enumerate(zip(block["names"], block["units"], strict=True)):
            cells = " | ".join(f"{block['values'][n][j]:.4g}" for n in names)
            lines.append(f"| {obj} [{unit}], {label} | {cells} |")
    for lc in ("no_load", "full_load"):
        for stem, text, factor, digits in PAPER_FIGURES:
            vals = t["figures"][f"{stem}_{lc}"]
            cells = " | ".join(f"{v * factor:.{digits}f}" for v in vals)
            lines.append(f"| {text}, {lc.replace('_', ' ')} | {cells} |")
    return "\n".join(lines)


def minibus_effects_block(d: Json) -> str:
    """docs/minibus.md's effects validation (``minibus_ride_effects.json``): per design
    and load case, per effect set, the spectral value's deviation from the long runs
    +- the runs' standard error (front / rear, %), then the speed paragraph."""
    s, rows = d["summary"], d["rows"]
    sets = list(dict.fromkeys(r["effects"] for r in rows))
    cell = {(r["effects"], r["design"], r["load_case"], r["end"]): r for r in rows}
    lines = [
        "| design, load case | " + " | ".join(x.replace("_", " ") for x in sets) + " |",
        "|---|" + "---|" * len(sets),
    ]
    for lc in dict.fromkeys(r["load_case"] for r in rows):
        for name in dict.fromkeys(r["design"] for r in rows):
            vals = [
                " / ".join(
                    f"{c['error_percent']:+.1f}±{c['time_se_percent']:.1f}"
                    for end in ("front", "rear")
                    for c in [cell[e, name, lc, end]]
                )
                for e in sets
            ]
            lines.append(f"| {name}, {lc.replace('_', ' ')} | " + " | ".join(vals) + " |")
    within = " | ".join(s[f"{e}_within_target"] for e in sets)
    lines.append(f"| within {s['target_percent']:g} % | {within} |")
    resolved = " | ".join(s[f"{e}_outside_by_2se"] for e in sets)
    lines.append(f"| outside by more than 2 standard errors | {resolved} |")
    ignored = " | ".join(f"{s[f'{e}_ignoring_max_abs_percent']:.0f}" for e in sets)
    lines.append(f"| largest deviation ignoring the effects (%) | {ignored} |")
    met_1 = met(s["meets_batch1_target_cpu"])
    inside = "within" if s["study_command_cpu_s"] <= s["target_study_s"] else "over"
    text = fill("minibus_effects.paragraph", s=s, met=met_1, study_met=inside)
    return "\n".join(lines) + "\n\n" + paragraph(text)


def minibus_stops_table(d: Json) -> str:
    """docs/minibus.md's criteria of the end stops' gain and the variants with their
    remainder (``minibus_stop_criteria.json``): per row the stop cells within target
    (front / rear), their range and the cells the Gaussian gain misses (%)."""
    lines = [
        "| stop's gain (and remainder) | within 2 % (front / rear) | range (%) "
        "| low corner loaded F / R, 1010 loaded R (%) |",
        "|---|---|---|---|",
    ]
    s = d["summary"]
    for c in [*s["criteria"].values(), *s["remainder"].values()]:
        f, r, r2 = c["missed_by_gaussian_percent"]
        lines.append(
            f"| {c['label']} | {c['within_target']} ({c['within_target_front'].split('/')[0]}"
            f" / {c['within_target_rear'].split('/')[0]}) | {c['error_min_percent']:+.1f} to "
            f"{c['error_max_percent']:+.1f} | {f:+.1f} / {r:+.1f}, {r2:+.1f} |"
        )
    return "\n".join(lines)


def planar_speed_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the planar linkage row from ``planar_speed.json``."""
    pymunk_s = s["pymunk_ms_per_candidate"] / 1000
    return fill("planar.result", s=s, pymunk_s=pymunk_s), fill("planar.target", s=s)


def first_run_cells(s: Json) -> tuple[str, str]:
    """(result, target) of the fresh install's first run from ``first_run.json``."""
    _require(s["all_ok"], "a first run's evaluation failed")
    met_first, met_import = met(s["meets_first_target"]), met(s["meets_import_target"])
    return fill("first_run.result", s=s), fill(
        "first_run.target", s=s, first=met_first, imported=met_import
    )


def render_performance(data: Mapping[str, Json]) -> str:
    """The "Performance" table: a row per benchmark, its cells from its summary."""
    cells = {
        "overhead": overhead_cells,
        "knc_speed": knc_speed_cells,
        "identify_reference": identify_cells,
        "tey2014_pipeline": tey_pipeline_cells,
        "minibus_speed": minibus_speed_cells,
        "ride_noise": ride_noise_cells,
        "minibus_study": minibus_study_cells,
        "planar_speed": planar_speed_cells,
        "first_run": first_run_cells,
    }
    seeds = ", ".join(sorted({str(r["seed"]) for r in data["identify_reference"]["rows"]}))
    values = {k: f(data[k]["summary"]) for k, f in cells.items()}
    return fill("performance.table", seeds=seeds, **values)


# ------------------------------------------------------------------ diagnosis
COMPONENT_FAMILIES = {"damper", "mr_damper", "friction_guide", "quarter_car_rig"}


def component_row(d: Json) -> str:
    """The component families' row from ``diagnosis_benchmark.json``."""
    s = d["summary"]
    _require(
        set(d["per_family"]) == COMPONENT_FAMILIES,
        f"diagnosis_benchmark families {sorted(d['per_family'])} differ from the README's list",
    )
    return fill(
        "diagnosis.component", s=s, top1=percent(s["single_top1_family"]),
        false_alarm=percent(s["control_false_alarm"]),
        heldout=percent(-s["median_heldout_reduction"]), param=percent(s["median_param_rel_err"]),
        median=seconds(s["median_seconds"]), max=seconds(s["max_seconds"]),
        cpu=seconds(s["max_cpu_seconds"]),
    )  # fmt: skip


def component_outside_row(d: Json) -> str:
    """The components' out-of-library row from ``diagnosis_benchmark.json``."""
    n = sum(1 for c in d["cases"] if c.get("outside"))
    k = sum(1 for c in d["cases"] if c.get("outside") and c.get("unexplained"))
    rate = percent(d["summary"]["outside_unexplained"])
    return fill("diagnosis.component_outside", n=n, k_of_n=count(k, n), rate=rate)


#: the blind user's conditions of ``diagnosis_benchmark.json`` in the README's words
CONDITION_WORDS = {
    "masses_undeclared": "quarter-car masses not declared",
    "sign_reversed": "output sign reversed, signs not declared",
    "input_missing": "a switched input not recorded",
}


def component_condition_rows(d: Json) -> list[str]:
    """One row per blind user's condition of ``diagnosis_benchmark.json`` (none where the
    run had none): named first on single effects, false alarms on the controls."""
    rows = []
    for cond, c in d.get("conditions", {}).items():
        a = c["all"]
        rows.append(
            fill(
                "diagnosis.component_condition",
                words=CONDITION_WORDS.get(cond, cond),
                n=a["n_cases"],
                named=percent(a["single_top1_family"]),
                alarms=percent(a["control_false_alarm"]),
                median=seconds(a["median_seconds"]),
                cpu=seconds(a["median_cpu_seconds"]),
            )
        )
    return rows


def independent_row(d: Json) -> str:
    """The independent generator's row from ``independent_diagnosis.json``."""
    a = d["summary"]["all"]
    k, n = a.get("parameters_within_20_percent", (0, 0))
    median = 100 * a.get("parameter_error_median", 0.0)
    params = fill("diagnosis.independent_params", median=median, k_of_n=count(k, n))
    return fill(
        "diagnosis.independent", seeds=d["seeds"], n=len(d["cases"]),
        named=count(*a["single_named_first"]), outside=count(*a["outside_unexplained"]),
        alarms=count(*a["control_false_alarms"]), params=f" {params} " if n else " ",
        median=seconds(a["wall_s_median"]), max=seconds(a["wall_s_max"]),
        cpu=seconds(a["cpu_s_max"]),
    )  # fmt: skip


def real_recordings_table(d: Json) -> str:
    """Every real component recording: held-out error before/after and on the rig's
    further recordings, from ``real_recordings.json``."""
    lines = [
        "| real recording | verdict (headline) | held-out RMS error: baseline -> final | "
        "further recordings of the rig, never fitted: final better | an unrecorded input "
        "flagged: fitted, further | time |",
        "|---|---|---|---|---|---|",
    ]
    for r in d["rows"]:
        others = r["other_recordings"]
        better = sum(o["after"] < o["before"] for o in others)
        flagged = sum(bool(o.get("missing_input")) for o in others)
        change = r["heldout_after"] / r["heldout_before"] - 1.0
        lines.append(
            f"| {r['case']} | {r['headline']} | {r['heldout_before']:.4g} -> "
            f"{r['heldout_after']:.4g} N ({percent(change, sign=True)}) | "
            f"{count(better, len(others)) if others else '-'} | "
            f"{'yes' if r.get('missing_input') else 'no'}, "
            f"{count(flagged, len(others)) if others else '-'} | {seconds(r['wall_s'])} s |"
        )
    return "\n".join(lines)


def knc_row(d: Json) -> str:
    """The K&C row from ``knc_diagnosis.json``."""
    s = d["summary"]
    one, detectable = s["one_effect_cases"], s["one_effect_detectable_cases"]
    controls = s["no_effect_cases"]
    return fill(
        "diagnosis.knc", s=s, top1=count(s["top1_accuracy_one_effect"] * one, one),
        detectable=count(s["top1_accuracy_one_effect_detectable"] * detectable, detectable),
        alarms=count(s["false_alarm_rate_no_effect"] * controls, controls),
        model=percent(s["median_model_error_ratio_effect_cases"] - 1),
        heldout=percent(s["median_heldout_ratio_effect_cases"] - 1),
        param=percent(s["median_param_rel_err"], 1),
        median=seconds(s["median_seconds_per_diagnosis"]),
        max=seconds(s["max_seconds_per_diagnosis"]),
        cpu=seconds(s["max_cpu_seconds_per_diagnosis"]),
        cpu_median=seconds(s["median_cpu_seconds_per_diagnosis"]),
    )  # fmt: skip


def knc_outside_row(d: Json) -> str:
    """The K&C row of physics outside the library from ``knc_outside.json``."""
    s = d["summary"]
    return fill(
        "diagnosis.knc_outside", n=s["cases"],
        k_of_n=count(s["reported_unexplained"] * s["cases"], s["cases"]),
        rate=percent(s["reported_unexplained"]),
        wrong=count(s["confident_wrong_names"], s["cases"]), median=seconds(s["median_cpu_s"]),
    )  # fmt: skip


def _part(d: Json, part: str) -> list[Json]:
    rows = [r for r in d["rows"] if r["part"] == part]
    _require(bool(rows), f"ride_diagnosis.json has no {part!r} rows")
    return rows


def ride_rows(d: Json) -> list[str]:
    """The minibus ride, out-of-library and road-profile rows from ``ride_diagnosis.json``."""
    s = d["summary"]
    ride, outside, road = _part(d, "ride"), _part(d, "ride (out of library)"), _part(d, "road")
    effect = [r for r in ride if r["truth"] != "none"]
    worst = max(
        float(r["param_rel_error_max"])
        for r in effect
        if math.isfinite(float(r["param_rel_error_max"]))
    )

    def cpus(rows: Sequence[Json]) -> str:
        c = [float(r["cpu_seconds"]) for r in rows]
        return f"{seconds(min(c))}-{seconds(max(c))} s"

    named = count(sum(bool(r["correct_top1"]) for r in effect), len(effect))
    return [
        fill(
            "diagnosis.ride", n=len(ride), named=named,
            alarms=count_text(s["ride_false_alarms"]),
            ratio=s["ride_heldout_rms_after_over_before_median"], worst=percent(worst, 1),
            cpus=cpus(ride), median=seconds(s["ride_cpu_seconds_median"]),
            baseline=seconds(s["speed_baseline_cpu_seconds_median_numpy_loop"]),
            compiled=seconds(s["speed_baseline_cpu_seconds_median_compiled"]),
        ),
        fill(
            "diagnosis.ride_outside", n=len(outside),
            wrong=count_text(s["ride_out_of_library_wrong_name_confident"]),
            flagged=count_text(s["ride_out_of_library_residual_flagged"]), cpus=cpus(outside),
        ),
        fill(
            "diagnosis.road", n=len(road), alarms=count_text(s["road_false_alarms_w2"]),
            found=count(sum(bool(r["correct_top1"]) for r in road if r["truth"] != "w=2 (none)"),
                        sum(r["truth"] != "w=2 (none)" for r in road)),
            w=s["road_w2.5_mean_fit"], median=f"{s['road_cpu_seconds_median']:.2f}",
        ),
        fill(
            "diagnosis.road_outside", n=len(_part(d, "road (out of library)")),
            wrong=count_text(s["road_out_of_library_wrong_name_confident"]),
            flagged=count_text(s["road_out_of_library_unexplained"]),
        ),
    ]  # fmt: skip


def _real(d: Json, case: str) -> Json:
    for r in d["real"]:
        if r["case"] == case:
            return r
    raise FigureError(f"diagnosis_benchmark.json has no {case!r} row")


def real_paragraph(bench: Json, ride: Json) -> str:
    """The "Real recordings" paragraph: EMPS, MR damper and damper dyno from the real rows
    of ``diagnosis_benchmark.json``, the measured road profiles from ``ride_diagnosis.json``.
    The drift inside each dyno speed (0.2-1.3 N/s) is in no JSON and stays static."""
    emps, mr, dyno = (_real(bench, f"real:{c}") for c in ("emps", "mr_damper", "damper_dyno"))
    _require(all(emps["expected_found"].values()), "EMPS: friction no longer named")
    _require(all(mr["expected_found"].values()), "MR damper: hysteresis no longer named")
    _require(bool(dyno["expected_found"].get("digressive")), "dyno: digressive curve not named")
    asymmetry: Json = dyno.get("asymmetry") or {}
    matched: Json | None = asymmetry.get("matched_speed")
    if not matched:
        raise FigureError("dyno: no matched-speed check recorded")
    _require(
        not matched["supported"] and matched["p_constant"] < 0.01,
        "dyno: the matched-speed verdict changed (constant rejected, asymmetry not named)",
    )
    roads = _part(ride, "road (real)")
    _require(
        len(roads) == 2 and all(r["named"] == "waviness_steeper" for r in roads),
        "measured road profiles: no longer both named waviness steeper",
    )
    # the values of the published model's structure (friction first on the baseline);
    # what the engine names beyond it follows
    c = emps.get("checks_first_element") or emps["checks"]
    fc, visc, off = c["coulomb_friction.f_c"], c["c"], c["force_offset.offset"]
    beyond = [k for k in str(emps["named"]).split("+")[1:] if k]
    groups = matched["groups"]
    hi = max(groups, key=lambda g: g["rebound_over_bump_raw"])
    lo = min(groups, key=lambda g: g["rebound_over_bump_raw"])
    w1, w2 = (float(r["w_fit"]) for r in roads)
    then = ", ".join(GUIDE_WORDS.get(k, k.replace("_", " ")) for k in beyond)
    return fill(
        "real.paragraph", fc=fc, visc=visc, off=off, then=f"; then {then}" if beyond else "",
        mr_gain=percent(-mr["heldout_reduction"]), dyno_gain=percent(-dyno["heldout_reduction"]),
        hi=hi, lo=lo, hi_gain=percent(hi["rebound_over_bump_raw"], 1, sign=True),
        lo_gain=percent(lo["rebound_over_bump_raw"], 1, sign=True),
        p_order=order_of(matched["p_constant"]), w1=w1, w2=w2,
    )  # fmt: skip


def render_diagnosis(data: Mapping[str, Json]) -> str:
    """The blind-benchmark table and the "Real recordings" paragraph."""
    bench, ride = data["diagnosis_benchmark"], data["ride_diagnosis"]
    return "\n".join(
        [
            "| family (reported seeds) | named first (one effect) | false alarms (no effect) "
            "| held-out RMS | effect parameters | time per diagnosis |",
            "|---|---|---|---|---|---|",
            component_row(bench),
            component_outside_row(bench),
            *component_condition_rows(bench),
            independent_row(data["independent_diagnosis"]),
            knc_row(data["knc_diagnosis"]),
            knc_outside_row(data["knc_outside"]),
            *ride_rows(ride),
            "",
            real_paragraph(bench, ride),
            "",
            real_recordings_table(data["real_recordings"]),
        ]
    )


RENDERERS = {"performance": render_performance, "diagnosis": render_diagnosis}


def knc_speed_tables(d: Json) -> str:
    """docs/knc.md's speed and memory tables from ``knc_speed.json``: time and peak
    memory per candidate of both paths at batch 1, 42 and 1000, the optimised path's
    memory over the batch sizes, and one at a time candidate by candidate."""
    s = d["summary"]
    rows = {(r["path"], r["batch"]): r for r in d["rows"]}
    names = {1: "one at a time", 42: "batch of 42", 1000: "batch of 1000"}
    lines = [
        "| mode | CPU ms / candidate | numpy objectives (same run) | sweep from Python (same "
        "run) | baseline (same run) | peak MB / candidate | baseline peak MB |",
        "|---|---|---|---|---|---|---|",
    ]
    for b, name in names.items():
        fast, py, base = rows["optimised", b], rows["python_sweep", b], rows["baseline", b]
        cs = rows["compiled_sweep", b]
        mb_fast = significant(fast["peak_mb_per_candidate"], 3)
        mb_base = significant(base["peak_mb_per_candidate"], 2)
        lines.append(
            f"| {name} | {fast['cpu_ms_per_candidate']:.2f} | {cs['cpu_ms_per_candidate']:.2f} | "
            f"{py['cpu_ms_per_candidate']:.2f} | "
            f"{base['cpu_ms_per_candidate']:.3g} | {mb_fast} | {mb_base} |"
        )
    mb = s["peak_mb_per_candidate"]
    lines += [
        "",
        "| batch | " + " | ".join(mb) + " |",
        "|---|" + "---|" * len(mb),
        "| peak MB / candidate | " + " | ".join(significant(v, 3) for v in mb.values()) + " |",
    ]
    alone = s["memory_one_at_a_time"]
    text = fill("knc_speed.alone", alone=alone, s=s)
    lines += ["", paragraph(text)]
    return "\n".join(lines)


#: docs/runs.md's words for the bare loops of ``overhead.json`` (by library)
BARE_LOOPS = {
    "pycma": "pycma `ask`/`tell`, 49-D sphere, population 42",
    "pymoo": "pymoo NSGA-II `ask`/`tell`, 30-D ZDT1, population 100",
    "optuna": "optuna NSGA-II batched `ask`/`tell`, 10-D ZDT1, population 50",
}
#: docs/runs.md's words for the workers study's problems (by case name in the JSON)
WORKER_PROBLEMS = {
    "Sphere (cheap)": "sphere (a cheap evaluation)",
    "KCIdentification": "K&C identification",
    "Burn 5 ms/call + 20 ms/design": "`Burn`: 5 ms per call + 20 ms per design",
}


def _ms(x: float) -> str:
    """Milliseconds with two significant figures below 10, whole above."""
    return significant(x, 2) if x < 10 else f"{x:.0f}"


def overhead_loop_table(d: Json) -> str:
    """docs/runs.md's table of the loop against the bare library loops (``overhead.json``)."""
    rows = {(r["library"], r["case"]): r for r in d["rows"]}
    lines = [
        "| bare loop | bare, ms/eval | suspenv, no archive: median; best/best | "
        "suspenv + archive: median; best/best |",
        "|---|---|---|---|",
    ]
    for lib, words in BARE_LOOPS.items():
        bare, lean, full = (
            rows[lib, c] for c in ("bare", "suspenv, no archive", "suspenv + archive")
        )
        lines.append(
            f"| {words} | {significant(bare['ms_per_eval'], 2)} | "
            f"{lean['ratio_vs_bare']:.2f}x; {lean['ratio_of_best']:.2f}x | "
            f"**{full['ratio_vs_bare']:.2f}x**; {full['ratio_of_best']:.2f}x |"
        )
    return "\n".join(lines)


def overhead_workers_block(d: Json) -> str:
    """docs/runs.md's workers study from ``overhead.json``: per problem the in-process CPU
    per batch and the problem's own part of it ``e``, the fixed cost per chunk ``k`` (the
    CPU difference between chunks of 1 design and the default, per extra chunk), the CPU
    and wall of 2 workers against 1, the wall predicted on 2 idle cores (the rest of the
    batch, in the main process, plus ``k + e / 2``), then the chunking's cost."""
    runs = [r for r in d["rows"] if r["library"] == "workers"]
    by = {r["case"]: r for r in runs}
    lines = [
        "| problem | in-process CPU per batch (the problem's `e`) | fixed cost per chunk `k` "
        "| CPU, 2 workers / 1 | wall, 2 workers / 1 (measured) | predicted wall on 2 idle "
        "cores |",
        "|---|---|---|---|---|---|",
    ]
    chunking = []
    free = min(r["cores_free_2proc"] for r in runs)
    for case, words in WORKER_PROBLEMS.items():
        one = by[f"{case}: workers=1, chunk=default"]
        two = by[f"{case}: workers=2, chunk=default"]
        five = by[f"{case}: workers=2, chunk=5"]
        single = by[f"{case}: workers=2, chunk=1"]
        batch = one["batch"]
        batches = one["evaluations"] / batch
        per_batch = 1e3 * one["cpu_s"] / batches
        # chunks per batch: 2 by default (one per worker), `batch` of 1 design
        k = 1e3 * (single["cpu_s"] - two["cpu_s"]) / (batches * (batch - 2))
        e = min(one["evaluation_ms_per_batch"], per_batch)
        rest = per_batch - e  # the strategy's and the loop's, in the main process
        predicted = rest + k + e / 2
        gain = per_batch / predicted
        verdict = f"{_ms(rest)} + {_ms(k)} + {_ms(e)} / 2 = {_ms(predicted)} ms per batch: " + (
            f"{gain:.1f}x faster" if gain > 1.05 else "no faster: the pool only adds"
        )
        lines.append(
            f"| {words} | {_ms(per_batch)} ms ({_ms(e)} ms) | {_ms(k)} ms | "
            f"{two['cpu_vs_workers_1']:.2f}x | {two['wall_vs_workers_1']:.2f}x "
            f"({batches:.0f} batches) | {verdict} |"
        )
        chunking.append(
            f"{words.split(':')[0]}: chunks of 5 designs {five['cpu_vs_workers_1']:.1f}x, of 1 "
            f"design {single['cpu_vs_workers_1']:.1f}x"
        )
    text = fill("overhead.workers", free=free, chunking="; ".join(chunking))
    lines += ["", paragraph(text)]
    return "\n".join(lines)


#: docs/diagnosis_knc.md's words for the K&C effect kinds
KNC_KIND_WORDS = {
    "coulomb_friction": "strut friction",
    "cubic_stiffness": "cubic",
    "lr_asymmetry": "L/R asymmetry",
    "sensor_gain": "sensor gain",
    "sensor_offset": "sensor offset",
}
#: ... and for where the hysteresis is
KNC_WHERE_WORDS = {"top_mount": "top mount", "lower_arm": "lower arm", "": "all three"}


def _knc_named(r: Json) -> str:
    """The named column of a K&C diagnosis row: kinds in the order named, hysteresis
    with its location (and the ambiguity the verdict states)."""
    if r["named"] == "none":
        return "none"
    words = []
    for kind in r["named"].split(","):
        if kind == "dahl_hysteresis":
            where = r["hysteresis_where"].partition("@")[2]
            text = f"hysteresis ({KNC_WHERE_WORDS[where]})"
            if r["where_ok"] is False and r["where_ok_or_ambiguous"]:
                text += ", true location stated not separable"
            words.append(text)
        else:
            words.append(KNC_KIND_WORDS[kind])
    return " + ".join(words)


def knc_diagnosis_tables(d: Json) -> str:
    """docs/diagnosis_knc.md's score table, top-1 by type and per-seed table from
    ``knc_diagnosis.json`` (targets: the issue's, as in the README)."""
    s = d["summary"]
    rows = d["rows"]
    one = [r for r in rows if r["n_true"] == 1]
    two = [r for r in rows if r["n_true"] == 2]
    none = [r for r in rows if r["n_true"] == 0]
    det, undet = [r for r in one if r["detectable"]], [r for r in one if not r["detectable"]]
    two_det = [r for r in two if r["detectable"]]
    effect = [r for r in rows if r["n_true"] > 0]
    extra = sum(len(set(r["named"].split(",")) - set(r["truth"].split(","))) for r in effect)
    located = [r for r in rows if r["where_ok"] is not None]

    def k_of(rs: list, key: str) -> str:
        return f"{sum(bool(r[key]) for r in rs)} / {len(rs)}"

    lines = [
        fill(
            "knc_diagnosis.scores", s=s, one_top1=k_of(one, "top1_ok"),
            det_top1=k_of(det, "top1_ok"), undet_top1=k_of(undet, "top1_ok"),
            two_all=k_of(two, "all_found"), two_det_all=k_of(two_det, "all_found"),
            alarms=f"{sum(r['false_alarms'] > 0 for r in none)} / {len(none)}",
            extra=extra, n_effect=len(effect), where_ok=k_of(located, "where_ok"),
            where_amb=k_of(located, "where_ok_or_ambiguous"),
            reduction=percent(1 - s["median_model_error_ratio_effect_cases"]),
            param=percent(s["median_param_rel_err"], 1),
        ),
        "",
    ]  # fmt: skip
    by_type = s["top1_by_case_type"]
    same = set(by_type.values())
    types = ", ".join(t.replace("@", " @ ") for t in by_type)
    text = (
        f"Top-1 naming by single-effect type: every type {same.pop().replace('/', ' / ')} "
        f"({types})."
        if len(same) == 1
        else "Top-1 naming by single-effect type: "
        + ", ".join(f"{t.replace('@', ' @ ')} {v.replace('/', ' / ')}" for t, v in by_type.items())
        + "."
    )
    lines += [paragraph(text), ""]
    lines += [
        "| seed | truth (type) | snr | named (hysteresis location) | held-out ratio: measured "
        "/ model error | param. error | wall / CPU s |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        truth = r["case_type"].replace("@", " @ ").replace("+", " + ")
        snr = r["snr"] or "-"
        if r["snr"] and not r["detectable"]:
            snr += " (< 5)"
        if r["named"] == "none" and r["heldout_ratio"] == 1.0 and r["model_error_ratio"] == 1.0:
            ratios = "1 / 1"
        else:
            ratios = f"{r['heldout_ratio']:.2f} / {r['model_error_ratio']:.2f}"
        err = r["param_rel_err"]
        err_text = "" if not math.isfinite(err) else percent(err, 1)
        lines.append(
            f"| {r['seed']} | {truth}, noise x{r['noise_scale']:.2f} | {snr} | {_knc_named(r)} | "
            f"{ratios} | {err_text} | {r['seconds']:.0f} / {r['cpu_seconds']:.0f} |"
        )
    return "\n".join(lines)


def tey_pipeline_paragraph(d: Json) -> str:
    """docs/tey2014.md's performance sentence from ``tey2014_pipeline.json``."""
    s = d["summary"]
    steps = {
        r["step"]: r["seconds"]
        for r in d["rows"]
        if not r["step"].startswith(("total", "baseline"))
    }
    slowest = max(steps, key=lambda k: steps[k])
    text = fill(
        "tey.paragraph", s=s, wall=seconds(s["pipeline_wall_s"]),
        where="in-process" if s["workers"] == 1 else f"{s['workers']} workers",
        bare=seconds(s["bare_evaluation_s"]), slowest=slowest.replace("_", " "),
        slowest_s=seconds(steps[slowest]), within="within" if s["within_target"] else "outside",
    )  # fmt: skip
    return paragraph(text)


#: the diagnosis screen's pattern names as docs/identify.md words them
SCREEN_WORDS = {"lr_asymmetry": "left/right asymmetry", "progressive": "cubic", "loop": "loop"}


def identify_reference_block(d: Json) -> str:
    """docs/identify.md's results on the reference car's test car from
    ``identify_reference.json``: which polish won, the table of the eight cases, and the
    noise-only errors."""
    rows = d["rows"]
    global_wins = [r for r in rows if r["answer"] == "polish from the CMA-ES best"]
    _require(
        all(
            r["answer"] in ("polish from the CMA-ES best", "polish from the start design")
            for r in rows
        ),
        "an answer other than the two polishes",
    )
    won = ", ".join(f"{r['case']} seed {r['seed']}" for r in global_wins) or "none"
    lines = [
        paragraph(fill("identify.answer", n_won=len(global_wins), n=len(rows), won=won)),
        "",
        fill("identify.header"),
    ]
    for r in rows:
        worst = r["identified_max_err_%"]
        names = ", ".join(SCREEN_WORDS.get(n, n) for n in r["named"].split(","))
        lines.append(
            fill(
                "identify.row",
                r=r,
                curves=count_text(r["curves_within_1.5"]),
                answer="CMA-ES best" if r["answer"].endswith("CMA-ES best") else "start design",
                worst=f"{worst:.2f}" if math.isfinite(worst) else "-",
                names="nothing" if r["named"] == "none" else names,
            )  # fmt: skip
        )
    looped = [r for r in rows if r.get("loop_curves_within_1.5")]
    if looped:
        lines += [
            "",
            paragraph(
                "The main job's loop (sides apart, the named hysteresis at the place that "
                "fits best, all refitted): "
                + "; ".join(
                    f"{r['case']} seed {r['seed']}: {count_text(r['loop_curves_within_1.5'])} "
                    f"measured curves (fitted, and the held-out test's when measured) within "
                    f"1.5 x noise (worst {r['loop_worst_rms_over_noise']:.2f}), "
                    f"held-out {r['held_out']} {r['held_out_worst_after']:.2f} x noise (first "
                    f"fit {r['held_out_worst_before']:.1f}), K&C sheet intervals holding the "
                    f"truth for {100 * r['sheet_coverage']:.0f} % of {r['sheet_values']} values"
                    for r in looped
                )
                + "."
            ),
        ]
    quiet = [r for r in rows if r["case"] == "noise only"]
    means = [r["all_mean_err_%"] for r in quiet]
    counts = " or ".join(map(str, sorted({r["identified"] for r in quiet})))
    text = fill(
        "identify.noise_only", counts=counts,
        worst=max(r["identified_max_err_%"] for r in quiet), mean=span(min(means), max(means)),
    )  # fmt: skip
    return "\n".join([*lines, "", paragraph(text)])


#: the blocks of the other documents (:data:`DOCUMENT_BLOCKS`), by block name
DOCUMENT_RENDERERS = {
    "overhead-loops": lambda data: overhead_loop_table(data["overhead"]),
    "overhead-workers": lambda data: overhead_workers_block(data["overhead"]),
    "identify-reference": lambda data: identify_reference_block(data["identify_reference"]),
    "knc-diagnosis": lambda data: knc_diagnosis_tables(data["knc_diagnosis"]),
    "tey-pipeline": lambda data: tey_pipeline_paragraph(data["tey2014_pipeline"]),
    "minibus-study": lambda data: minibus_study_paragraph(data["minibus_study"]),
    "minibus-paper": lambda data: minibus_paper_table(data["minibus_objectives"]),
    "minibus-effects": lambda data: minibus_effects_block(data["minibus_ride_effects"]),
    "minibus-stops": lambda data: minibus_stops_table(data["minibus_stop_criteria"]),
    "knc-speed": lambda data: knc_speed_tables(data["knc_speed"]),
}


# ------------------------------------------------------------------ blocks
def load(bench_dir: Path = BENCH_DIR) -> dict[str, Json]:
    """Every JSON file the blocks read, by file stem."""
    data: dict[str, Json] = {}
    for name in (n for names in SOURCES.values() for n in names):
        path = bench_dir / f"{name}.json"
        try:
            data[name] = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise FigureError(f"{path} does not parse (is a benchmark writing it?): {exc}") from exc
    return data


def render(data: Mapping[str, Json]) -> dict[str, str]:
    """README.md's blocks: block name -> rendered Markdown."""
    return {name: fn(data) for name, fn in RENDERERS.items()}


def render_documents(data: Mapping[str, Json]) -> dict[str, dict[str, str]]:
    """The other documents' blocks: path (relative to the repository) -> block name ->
    rendered Markdown."""
    return {
        doc: {name: DOCUMENT_RENDERERS[name](data) for name in names}
        for doc, names in DOCUMENT_BLOCKS.items()
    }


def markers(name: str) -> tuple[str, str]:
    return f"<!-- readme-table:{name}:begin -->", f"<!-- readme-table:{name}:end -->"


def read_block(text: str, name: str, label: str = "README.md") -> str:
    """The text between block ``name``'s markers (without the newlines next to them);
    ``label`` names the document in the error."""
    begin, end = markers(name)
    _require(
        text.count(begin) == 1 and text.count(end) == 1 and text.index(begin) < text.index(end),
        f"{label} needs one {begin} ... {end} pair",
    )
    return text.split(begin, 1)[1].split(end, 1)[0].strip("\n")


def write_block(text: str, name: str, body: str) -> str:
    """``text`` with block ``name`` replaced by ``body``."""
    read_block(text, name)  # the markers are there, once
    begin, end = markers(name)
    head, rest = text.split(begin, 1)
    tail = rest.split(end, 1)[1]
    return f"{head}{begin}\n{body}\n{end}{tail}"


def stale_blocks(text: str, blocks: Mapping[str, str], label: str = "README.md") -> dict[str, str]:
    """Block name -> unified diff (the document ``label`` -> rendering) for every block
    that differs."""
    out = {}
    for name, body in blocks.items():
        old = read_block(text, name, label)
        if old != body:
            diff = difflib.unified_diff(
                old.splitlines(), body.splitlines(), label, "rendering", lineterm="", n=0
            )
            out[name] = "\n".join(diff)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m benchmarks.readme [--check] [--readme PATH] [--docs-root DIR]
    [--bench-dir DIR]``."""
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.readme",
        description="Render the README's (and docs') benchmark figures from "
        "docs/benchmarks/*.json.",
    )
    parser.add_argument("--check", action="store_true", help="exit 1 if a document is stale")
    parser.add_argument("--readme", type=Path, default=README)
    parser.add_argument(
        "--docs-root", type=Path, default=ROOT, help="where the other documents' paths start"
    )
    parser.add_argument("--bench-dir", type=Path, default=BENCH_DIR)
    args = parser.parse_args(argv)
    try:
        data = load(args.bench_dir)
        documents = {args.readme: render(data)}
        documents |= {args.docs_root / doc: b for doc, b in render_documents(data).items()}
        texts = {path: path.read_text() for path in documents}
        stale = {
            path: stale_blocks(texts[path], blocks, path.name) for path, blocks in documents.items()
        }
    except FigureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    for path, blocks in documents.items():
        for name in blocks:
            print(f"{path.name} {name}: {'changed' if name in stale[path] else 'up to date'}")
            if name in stale[path]:
                print(stale[path][name])
    changed = [path for path in documents if stale[path]]
    if args.check:
        for path in changed:
            print(f"{path} is stale: run python -m benchmarks.readme", file=sys.stderr)
        return 1 if changed else 0
    for path in changed:
        text = texts[path]
        for name, body in documents[path].items():
            text = write_block(text, name, body)
        path.write_text(text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
