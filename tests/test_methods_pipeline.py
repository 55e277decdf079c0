"""The "tey2014" pipeline end to end on a small problem with a known answer."""

from __future__ import annotations

import numpy as np
import pytest
from strict_json import strict_loads
from synthetic_problem import TRUTH, SyntheticIdentification

from suspenv.core.errors import ValidationError
from suspenv.methods.tey2014.pipeline import run_study, study_options
from suspenv.registry import pipeline_function

SYNTHETIC = "synthetic_problem:SyntheticIdentification"


def _config(**study):
    return {
        "name": "syn",
        "seed": 3,
        "budget": 14 * 16,
        "problem": {"name": SYNTHETIC},
        "strategy": {"name": "cmaes", "options": {"popsize": 14}},
        "study": {"doe_samples": 150, "top": 10, "profile_points": 5, **study},
        "run": {"progress": False},
    }


def test_pipeline_recovers_the_planted_structure_and_writes_the_report(tmp_path):
    run = pipeline_function("tey2014")
    summary = run(_config(), tmp_path)
    # planted: 4 groups of objectives -> 4 clusters, one kept objective per group
    assert summary["k"] == 4
    groups = sorted(name[0] for name in summary["kept_objectives"])
    assert groups == ["a", "b", "c", "d"]
    # planted: spare_1 and spare_2 drive nothing -> flat profiles
    assert summary["flat_parameters"] == ["spare_1", "spare_2"]
    # identifiable parameters come back near the truth (analytic problem, truth known)
    ident = summary["identified"]
    assert ident["stiffness_a"][0] == pytest.approx(TRUTH["stiffness_a"], abs=0.45)  # 5 % range
    assert ident["c"][0] == pytest.approx(TRUTH["c"], abs=5.0)  # 5 % of range
    b_sum = ident["b1"][0] + ident["b2"][0]  # only the sum is observable
    assert b_sum == pytest.approx(TRUTH["b1"] + TRUTH["b2"], abs=0.1)
    # the identified model fits far better than the initial one, on all objectives
    # (the truth has zero mismatches, the lowest possible rank-sum)
    tot = summary["fixed_rank_sum_all"]
    assert tot["truth"] <= tot["identified"] < tot["initial"]
    assert tot["identified"] - tot["truth"] < 0.2 * (tot["initial"] - tot["truth"])
    # the report and its figures
    report = tmp_path / "report.md"
    text = report.read_text()
    for fig in (
        "sensitivity_heatmap",
        "dendrogram",
        "silhouette",
        "convergence",
        "rank_sum_vs_euclidean",
        "profiles",
        "recovery",
        "curves_test_A",
    ):
        assert f"figures/{fig}.png" in text
        assert (tmp_path / "figures" / f"{fig}.png").stat().st_size > 1000
    for heading in ("Table 1", "Table 2", "cophenetic correlation", "Flat directions"):
        assert heading in text
    # strict JSON as every run writer's: no NaN or Infinity tokens (null instead)
    saved = strict_loads((tmp_path / "study.json").read_text())
    assert (tmp_path / "summary.json").read_text() == (tmp_path / "study.json").read_text()
    assert saved["kept_objectives"] == summary["kept_objectives"]
    # run-summary keys for `suspenv show` / `suspenv compare`: best-so-far never rises
    curve = [v for v in saved["quality_curve"] if v is not None]
    assert np.all(np.diff(curve) <= 0) and saved["best_quality"] == curve[-1]
    assert saved["n_evaluations"] == 150 + 14 * 16


def test_rerun_resumes_and_invalid_designs_never_enter_the_identification(tmp_path):
    cfg = _config(report=False, profile_points=0)
    first = run_study(cfg, tmp_path)
    again = run_study(cfg, tmp_path)  # archives complete: nothing is re-evaluated
    np.testing.assert_array_equal(first.cmaes.x, again.cmaes.x)
    np.testing.assert_array_equal(first.identification.mean, again.identification.mean)
    assert again.profiles is None and again.local is None
    # infeasible (d1 + d2 > 1.8) and failed (spare_2 > 0.98) designs are not ranked
    valid = first.cmaes.valid
    assert set(first.identification.top_rows) <= set(np.flatnonzero(valid))
    assert np.isnan(first.identification.fitness[~valid]).all()
    assert (first.doe.ok == (first.doe.x[:, 7] <= 0.98)).all()
    assert (~first.doe.valid).sum() > 0  # the planted regions were actually sampled


def test_no_plots_gives_the_report_without_figures(tmp_path):
    cfg = _config(profile_points=0)
    cfg["budget"] = 14 * 2
    cfg["run"]["plots"] = False  # `suspenv run --no-plots`
    pipeline_function("tey2014")(cfg, tmp_path)
    text = (tmp_path / "report.md").read_text()
    assert "Table 1" in text and ".png" not in text
    assert not (tmp_path / "figures").exists()


def test_sensitivity_on_signed_responses_sees_monotone_influences(tmp_path):
    # metric a_gradient = stiffness_a exactly (synthetic problem): its signed response is
    # increasing in stiffness_a -> Spearman +1; the mismatch |residual| is V-shaped
    cfg = _config(report=False, profile_points=0)
    cfg["budget"] = 14 * 2
    study = run_study(cfg, tmp_path / "responses")  # default: signed, from the DoE archive
    assert study.sensitivity_source == "signed responses"
    assert study.sensitivity.rho[0, 0] == pytest.approx(1.0)
    cfg["study"]["sensitivity_on"] = "mismatches"
    mismatch = run_study(cfg, tmp_path / "mismatches")
    assert mismatch.sensitivity_source == "mismatches"
    assert abs(mismatch.sensitivity.rho[0, 0]) < 0.9


def test_a_changed_study_does_not_resume_a_foreign_archive(tmp_path):
    cfg = _config(report=False, profile_points=0)
    cfg["budget"] = 14 * 2
    first = run_study(cfg, tmp_path)
    cfg["study"]["k_criterion"] = "silhouette"
    cfg["study"]["k_max"] = 3  # at most 3 clusters: other kept objectives than the first run
    assert first.selection.k == 4
    with pytest.raises(ValidationError, match="holds other objectives"):
        run_study(cfg, tmp_path)


def test_study_options_are_validated():
    with pytest.raises(ValidationError, match="unknown key study.doe_sample"):
        study_options({"study": {"doe_sample": 10}})
    with pytest.raises(ValidationError, match="study.top"):
        study_options({"study": {"top": 0}})
    with pytest.raises(ValidationError, match="k_criterion"):
        study_options({"study": {"k_criterion": "elbow"}})
    opts = study_options({})
    assert opts["doe_samples"] == 500 and opts["top"] == 20  # the paper's settings


@pytest.mark.parametrize("name", ["tey2014", "tey2014_quick"])
def test_experiment_configs_are_valid(name):
    from pathlib import Path

    from suspenv.runs.config import load_config

    path = Path(__file__).resolve().parents[1] / "experiments" / f"{name}.toml"
    cfg = load_config(path)
    assert cfg["pipeline"] == "tey2014"
    opts = study_options(cfg)
    assert cfg["problem"]["name"] == "KCIdentification"
    if name == "tey2014":  # the paper's settings
        assert (opts["doe_samples"], cfg["budget"], opts["top"]) == (500, 2250, 20)
        assert cfg["strategy"]["options"]["popsize"] == 42


def test_synthetic_problem_truth_has_zero_mismatch():
    p = SyntheticIdentification()
    b = p.evaluate(p.truth_design()[None, :])
    assert b.ok[0] and np.all(b.objectives == 0.0)


def test_study_json_writes_null_where_a_number_is_undefined(tmp_path):
    # flat_tol 0: no parameter is flat, so the mean recovery error of the flat ones is
    # undefined (NaN in memory); study.json says null, as every run writer does
    cfg = _config(report=False, flat_tol=0.0)
    cfg["budget"] = 14 * 2
    pipeline_function("tey2014")(cfg, tmp_path)
    saved = strict_loads((tmp_path / "study.json").read_text())
    assert saved["flat_parameters"] == []
    assert saved["recovery_error_%_range"]["mean_flat"] is None
    assert saved["recovery_error_%_range"]["mean_identifiable"] > 0
