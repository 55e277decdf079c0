"""`suspenv compare` on real run directories: grouping, pooling refusals, the ZDT1 ranking,
the IOHprofiler export, the tidy loader and the command line.

Each user report is reproduced first (what the first `compare` did with these runs), then
the fix is checked against an independent reference (the runs' own archives and
summaries, pymoo's hypervolume, hand-written expectations).
"""

from __future__ import annotations

import json
import shutil
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from suspenv.analysis import compare, load_run, runs_table, tidy
from suspenv.analysis.ioh import HEADER
from suspenv.cli.main import main
from suspenv.core.errors import ValidationError
from suspenv.core.result import EvaluationBatch
from suspenv.reports.analysis import write_comparison
from suspenv.runs.archive import RunArchive
from suspenv.runs.config import validate
from suspenv.runs.runner import run_experiment


def read_ioh(folder: Path) -> list[dict]:
    """Parse the IOHprofiler export back: one dict per JSON meta file, with ``meta`` (the
    JSON) and ``scenarios``: per scenario a list of (evaluations, raw_y) array pairs, in
    order. Raises ValidationError when a ``.dat`` file disagrees with its JSON."""
    out = []
    for meta_path in sorted(Path(folder).rglob("IOHprofiler_f*.json")):
        meta = json.loads(meta_path.read_text())
        scenarios = []
        for sc in meta["scenarios"]:
            lines = (meta_path.parent / sc["path"]).read_text().splitlines()
            runs: list[list[tuple[int, float]]] = []
            for line in lines:
                if line.strip() == HEADER:
                    runs.append([])
                elif line.strip():
                    if not runs:
                        raise ValidationError(f"{sc['path']}: data before the first header")
                    e, y = line.split()
                    runs[-1].append((int(e), float(y)))
            if len(runs) != len(sc["runs"]):
                raise ValidationError(
                    f"{sc['path']}: {len(runs)} runs in the data, {len(sc['runs'])} in the JSON"
                )
            scenarios.append(
                {
                    "dimension": sc["dimension"],
                    "runs": [
                        (np.array([e for e, _ in r], int), np.array([y for _, y in r]))
                        for r in runs
                    ],
                }
            )
        out.append({"path": meta_path, "meta": meta, "scenarios": scenarios})
    return out


def _run(out: Path, name: str, problem: dict, strategy: dict, seed: int, budget: int) -> Path:
    cfg = validate(
        {
            "name": name,
            "seed": seed,
            "budget": budget,
            "problem": problem,
            "strategy": strategy,
            "run": {"output": str(out), "plots": False, "progress": False},
        }
    )
    return run_experiment(cfg)[0]


SPHERE4 = {"name": "Sphere", "options": {"dim": 4}}


@pytest.fixture(scope="module")
def sphere_runs(tmp_path_factory) -> dict[str, list[Path]]:
    out = tmp_path_factory.mktemp("sphere")
    runs: dict[str, list[Path]] = defaultdict(list)
    for seed in (1, 2, 3):
        runs["cmaes6"].append(
            _run(out, "cmaes6", SPHERE4, {"name": "cmaes", "options": {"popsize": 6}}, seed, 120)
        )
        runs["cmaes12"].append(
            _run(out, "cmaes12", SPHERE4, {"name": "cmaes", "options": {"popsize": 12}}, seed, 120)
        )
    for seed in (1, 2):
        runs["random"].append(_run(out, "random", SPHERE4, {"name": "random"}, seed, 120))
        runs["random60"].append(_run(out, "random60", SPHERE4, {"name": "random"}, seed + 2, 60))
        runs["dim5"].append(
            _run(
                out, "dim5", {"name": "Sphere", "options": {"dim": 5}}, {"name": "random"}, seed, 60
            )
        )
    return runs


# ------------------------------------------------------------- (a) grouping
def test_same_strategy_name_different_popsize_gives_two_groups(sphere_runs, tmp_path):
    dirs = sphere_runs["cmaes6"] + sphere_runs["cmaes12"]
    # the report: grouped by name only, CMA-ES with two populations became one group of 6
    names = {json.loads((d / "summary.json").read_text())["strategy"] for d in dirs}
    assert names == {"cmaes"}
    result = write_comparison(dirs, tmp_path, figures=False)
    table = result["table"]
    assert len(table) == 2 and all(r["runs"] == 3 for r in table)
    by_pop = {r["differs"]["popsize"]: r for r in table}
    assert set(by_pop) == {6, 12}
    for pop, row in by_pop.items():
        assert row["group"] == f"cmaes[{row['hash']}]" and len(row["hash"]) == 8
        # reference: the group's seeds and best values, read from its own summaries
        own = [d for d in dirs if f"cmaes{pop}-" in d.name]
        best = [json.loads((d / "summary.json").read_text())["best_quality"] for d in own]
        assert row["seeds"] == [1, 2, 3]
        assert row["best_min"] == min(best) and row["best_max"] == max(best)
    # the hash is stable: recomputed from the run alone, and the seed does not enter it
    hashes = {load_run(d).strategy_hash for d in sphere_runs["cmaes6"]}
    assert hashes == {by_pop[6]["hash"]}


def test_one_configuration_keeps_one_hash_on_every_dimension(tmp_path):
    # the report: CMA-ES's default population depends on the dimension (4 + 3 ln d), so
    # one user configuration got one hash per problem size, one profile line each
    runs = []
    for dim in (4, 6):
        sphere = {"name": "Sphere", "options": {"dim": dim}}
        for seed in (1, 2):
            runs.append(_run(tmp_path, f"d{dim}", sphere, {"name": "cmaes"}, seed, 40))
            runs.append(
                _run(
                    tmp_path,
                    f"p7d{dim}",
                    sphere,
                    {"name": "cmaes", "options": {"popsize": 7}},
                    seed,
                    42,
                )
            )
    res = compare(runs, suite=True)
    assert len(res.profile["solvers"]) == 2  # the default, and popsize = 7
    for p in res.result["problems"]:
        dim = p["config"]["options"]["dim"]
        by = {g["options"]["popsize"]: g for g in p["groups"]}
        assert set(by) == {None, 7}
        # the values the runs used, beside: cma's default 4 + floor(3 ln d) (Hansen 2016)
        assert by[None]["resolved_options"]["popsize"] == 4 + int(3 * np.log(dim))
        assert by[7]["resolved_options"]["popsize"] == 7
    hashes = {(r.strategy_options["popsize"], r.strategy_hash) for r in map(load_run, runs)}
    assert len(hashes) == 2


def test_defaults_filled_in_make_equal_problems_equal(sphere_runs, tmp_path):
    # {"dim": 4} given vs the same run re-labelled with the default filled in explicitly
    src = sphere_runs["random"][0]
    copy = tmp_path / "copy"
    shutil.copytree(src, copy)
    s = json.loads((copy / "summary.json").read_text())
    s["problem_options"] = {"dim": 4, "delay_s": 0.0}
    (copy / "summary.json").write_text(json.dumps(s))
    assert load_run(copy).problem_hash == load_run(src).problem_hash


# -------------------------------------------------------- (b) problem options
def test_different_problem_options_refused_naming_the_key(sphere_runs, tmp_path):
    dirs = sphere_runs["random"] + sphere_runs["dim5"]
    with pytest.raises(ValidationError) as e:
        write_comparison(dirs, tmp_path, figures=False)
    assert "options.dim: 4 -> 5" in str(e.value)
    assert "one problem configuration" in str(e.value) and "--suite" in str(e.value)
    # --suite: each problem reported on its own, a performance profile across them
    res = compare(dirs, suite=True)
    assert len(res.problems) == 2
    assert res.profile is None  # one strategy configuration: nothing to profile
    res = compare(
        dirs + sphere_runs["cmaes6"] + sphere_runs["cmaes12"],
        suite=True,
        allow_unequal_budgets=True,
    )
    prof = res.profile
    assert prof is not None and prof["n_problems"] == 2
    assert all(0 <= v <= 1 for row in prof["rho"] for v in row)


# ----------------------------------------------------------- (c) budgets
def test_unequal_budgets_refused_in_a_group_and_flagged_between_groups(sphere_runs, tmp_path):
    pooled = sphere_runs["random"] + sphere_runs["random60"]  # one configuration, 120 and 60
    with pytest.raises(ValidationError) as e:
        write_comparison(pooled, tmp_path, figures=False)
    msg = str(e.value)
    assert "different budgets" in msg and "60 evaluations (seeds [3, 4])" in msg
    assert "120 evaluations (seeds [1, 2])" in msg and "--allow-unequal-budgets" in msg
    ok = write_comparison(pooled, tmp_path, figures=False, allow_unequal_budgets=True)
    assert ok["problems"][0]["common_budget"] == 60
    # between groups: flagged in the table and the JSON, compared at the common budget
    mixed = sphere_runs["cmaes6"] + sphere_runs["random60"]
    res = write_comparison(mixed, tmp_path, figures=False)
    prob = res["problems"][0]
    assert all(r["unequal_budget"] for r in res["table"])
    assert any(f.startswith("unequal budgets") for f in prob["flags"])
    assert prob["common_budget"] == 60
    # random search evaluates in batches of 50 and never truncates one: 50 of 60 used,
    # flagged, and its best kept up to its budget
    assert any(
        f.startswith("stopped before their budget") and "random60-seed3" in f for f in prob["flags"]
    )
    # reference: each group's median at 60 evaluations, from the summaries' curves
    for row in res["table"]:
        label = row["group"]
        runs = [g for g in prob["groups"] if g["group"] == label][0]["runs"]
        curves = [
            json.loads((Path(r["run"]) / "summary.json").read_text())["quality_curve"] for r in runs
        ]
        at60 = [c[min(59, len(c) - 1)] for c in curves]
        assert row["median"] == pytest.approx(float(np.median(at60)))
    md = (tmp_path / "compare.md").read_text()
    assert "**Flag:** unequal budgets" in md and "| 120 (unequal) |" in md


def test_legacy_fields_and_figures(sphere_runs, tmp_path):
    dirs = sphere_runs["cmaes6"] + sphere_runs["random"]
    result = write_comparison(dirs, tmp_path)
    rows = {r["strategy"]: r for r in result["table"]}
    assert rows["cmaes"]["runs"] == 3 and rows["random"]["seeds"] == [1, 2]
    assert result["problem"] == "Sphere" and result["quality_name"]
    for f in (
        "compare.json",
        "compare.md",
        "convergence.png",
        "compare.png",
        "ecdf.png",
        "fixed_target.png",
        "profile.png",
    ):
        assert (tmp_path / f).stat().st_size > 500, f
    on_disk = json.loads((tmp_path / "compare.json").read_text())
    assert on_disk["table"] == result["table"]
    prob = result["problems"][0]
    assert prob["f_opt"] == 0.0  # Sphere's known optimum
    # ERT reference: recomputed here from the summaries' curves at the largest target
    target = prob["targets"][0]
    for g in prob["groups"]:
        spent, hits = 0, 0
        for r in g["runs"]:
            curve = json.loads((Path(r["run"]) / "summary.json").read_text())["quality_curve"]
            first = next(
                (i + 1 for i, v in enumerate(curve) if v is not None and v <= target), None
            )
            spent += first if first is not None else len(curve)
            hits += first is not None
        row = [x for x in prob["fixed_target"] if x["group"] == g["group"]][0]
        assert row["ert"] == pytest.approx(spent / hits)


def test_a_run_given_twice_and_an_unfinished_directory_are_refused(sphere_runs, tmp_path):
    d = sphere_runs["random"][0]
    with pytest.raises(ValidationError, match="given twice"):
        compare([d, d])
    with pytest.raises(ValidationError, match="not a finished run directory"):
        compare([tmp_path])


# ---------------------------------------------------------------- (d) ZDT1
@pytest.fixture(scope="module")
def zdt1_runs(tmp_path_factory) -> dict[str, list[Path]]:
    out = tmp_path_factory.mktemp("zdt1")
    zdt = {"name": "ZDT1", "options": {}}
    return {
        "cmaes": [_run(out, "ws_cmaes", zdt, {"name": "cmaes"}, s, 1000) for s in (1, 2, 3)],
        "nsga2": [
            _run(
                out,
                "nsga2",
                zdt,
                {"name": "pymoo_nsga2", "options": {"population_size": 20}},
                s,
                1000,
            )
            for s in (1, 2, 3)
        ],
    }


def test_zdt1_nsga2_beats_weighted_sum_cmaes_by_hypervolume(zdt1_runs, tmp_path):
    from pymoo.indicators.hv import HV

    dirs = zdt1_runs["cmaes"] + zdt1_runs["nsga2"]
    result = write_comparison(dirs, tmp_path, ioh=True)
    rows = {r["strategy"]: r for r in result["table"]}
    # the report: by the sum of objectives (the runs' own quality then) CMA-ES looked
    # better; ZDT1 has no scalar quality now, so the table shows no "best" at all
    for row in rows.values():
        assert row["best_median"] is None and row["best_min"] is None
    prob = result["problems"][0]
    assert prob["measure_kind"] == "hypervolume deficit"
    # every run has feasible rows, though no quality curve: no such flag
    assert not any("no feasible evaluation" in f for f in prob["flags"])
    mo = prob["multiobjective"]
    assert mo["reference_point"] == [pytest.approx(1.1), pytest.approx(1.1)]
    assert mo["hv_reference"] == pytest.approx(1.21 - 1 / 3)
    # reference: pymoo's hypervolume of each whole archive, reference point (1.1, 1.1)
    hv = {}
    for g in mo["groups"]:
        label = g["group"]
        runs = [x for x in prob["groups"] if x["group"] == label][0]["runs"]
        for r, mine in zip(runs, g["hypervolume"], strict=True):
            with RunArchive(r["run"]) as a:
                F = a.arrays()["objectives"]
            assert mine == pytest.approx(HV(ref_point=np.array([1.1, 1.1]))(F), rel=1e-12)
        hv[label.split("[")[0]] = g["hypervolume"]
        assert all(v > 0 for v in g["igd"])
    # by hypervolume NSGA-II is better on every seed, and so in the table
    assert min(hv["pymoo_nsga2"]) > max(hv["cmaes"])
    assert rows["pymoo_nsga2"]["median"] < rows["cmaes"]["median"]
    igd = {g["group"].split("[")[0]: g["igd_median"] for g in mo["groups"]}
    assert igd["pymoo_nsga2"] < igd["cmaes"]
    pair = prob["rank_tests"]["pairs"][0]
    assert "not separable with 3 and 3 seeds" in pair["verdict"]  # honest: p >= 0.1
    assert (tmp_path / "hypervolume.png").stat().st_size > 1000
    # the IOHprofiler export parses back to the compared curves
    parsed = read_ioh(tmp_path / "ioh")
    assert len(parsed) == 2
    for item in parsed:
        meta = item["meta"]
        assert meta["maximization"] is False and meta["function_id"] == 1
        assert meta["attributes"] == ["evaluations", "raw_y"]
        label = meta["algorithm"]["name"]
        (sc,) = item["scenarios"]
        assert sc["dimension"] == 6
        group = [x for x in prob["groups"] if x["group"] == label][0]
        assert len(sc["runs"]) == 3
        for (evals, ys), r, jr in zip(
            sc["runs"], group["runs"], meta["scenarios"][0]["runs"], strict=True
        ):
            assert evals[-1] == r["evaluations"] == jr["evals"] <= 1000  # as long as it ran
            assert ys[-1] == pytest.approx(r["final"], rel=1e-9)
            assert (np.diff(ys[:-1]) < 0).all()  # improvements only
            assert jr["best"]["y"] == pytest.approx(r["final"])


# ------------------------------------------------- Tey-normalised qualities
def _tey_like(path: Path, seed: int, best: float, doe_shift: float) -> Path:
    """A run directory as a tey2014 run writes it: the quality normalised on its own DoE."""
    path.mkdir(parents=True)
    curve = [None, best + 3.0, best + 1.0, best]
    summary = {
        "problem": "KCIdentification",
        "seed": seed,
        "strategy": "cmaes",
        "budget": 4,
        "n_evaluations": 14,
        "kept_objectives": ["a", "b"],
        "quality_name": "DoE-normalised rank-sum",
        "best_quality": best,
        "quality_curve": curve,
        "wall_time_s": 1.0,
    }
    (path / "summary.json").write_text(json.dumps(summary))
    (path / "config.resolved.toml").write_text(
        f'seed = {seed}\npipeline = "tey2014"\nbudget = 4\n\n[problem]\nname = "KCIdentification"'
        '\n\n[strategy]\nname = "cmaes"\n\n[study]\ndoe_samples = 10\n'
    )
    rng = np.random.default_rng(0)
    F = rng.uniform(size=(10, 2)) + doe_shift
    with RunArchive(path / "doe") as a:
        a.append(
            0,
            list(range(10)),
            np.zeros((10, 2)),
            np.zeros((10, 2)),
            EvaluationBatch(F, np.zeros((10, 0)), np.ones(10, bool), [""] * 10),
            0.1,
        )
    return path


def test_tey_runs_normalised_on_different_does_are_not_pooled(tmp_path):
    a = _tey_like(tmp_path / "tey-seed1", 1, -6.50, 0.0)
    b = _tey_like(tmp_path / "tey-seed2", 2, 1.85, 0.5)
    # the report: the first compare averaged -6.50 and 1.85 into one strategy row
    assert np.mean([-6.50, 1.85]) == pytest.approx(-2.325)
    with pytest.raises(ValidationError) as e:
        compare([a, b])
    msg = str(e.value)
    assert "normalisation: 'doe:" in msg and "design of experiments" in msg
    assert "not comparable" in msg and "tey-seed1" in msg and "tey-seed2" in msg
    # the same design of experiments: the same normalisation, pooled
    c = _tey_like(tmp_path / "tey-copy", 3, 1.0, 0.0)
    res = compare([a, c])
    (row,) = res.result["table"]
    assert row["runs"] == 2 and res.result["problems"][0]["multiobjective"]["skipped"]


# ------------------------------------------------------------- loader, CLI
def test_tidy_loader_is_long_form_for_pandas(sphere_runs):
    pd = pytest.importorskip("pandas")
    dirs = sphere_runs["cmaes6"][:2] + sphere_runs["random"][:1]
    t = tidy(dirs)
    df = pd.DataFrame(t)
    # random search used 100 of its 120 (batches of 50 are never truncated)
    assert len(df) == 120 + 120 + 100 and set(df["seed"]) == {1, 2}
    assert {"evaluation", "best_so_far", "objective:f", "feasible", "group"} <= set(df.columns)
    first = df[df["run"] == dirs[0].name]
    s = json.loads((dirs[0] / "summary.json").read_text())
    np.testing.assert_array_equal(first["best_so_far"].to_numpy(), s["quality_curve"])
    with RunArchive(dirs[0]) as a:
        np.testing.assert_array_equal(
            first["objective:f"].to_numpy(), a.arrays()["objectives"][:, 0]
        )
    per_run = pd.DataFrame(runs_table(dirs))
    assert list(per_run["evaluations"]) == [120, 120, 100]
    assert per_run["best_quality"].iloc[0] == s["best_quality"]


def test_tidy_of_multiobjective_runs_has_designs_and_hypervolume(zdt1_runs):
    # the report: no design-variable columns, and best_so_far was the sum of objectives
    dirs = zdt1_runs["cmaes"][:1] + zdt1_runs["nsga2"][:1]
    t = tidy(dirs)
    assert np.isnan(t["best_so_far"]).all()  # a sum across objectives is never shown
    with RunArchive(dirs[0]) as a:
        arrays, meta = a.arrays(), a.meta()
    first = t["run"] == dirs[0].name
    for j, (name, unit) in enumerate(
        zip(meta["parameter_names"], meta["parameter_units"], strict=True)
    ):
        np.testing.assert_array_equal(t[f"design:{name} [{unit or '-'}]"][first], arrays["x"][:, j])
    # the hypervolume column is compare's (the same front, normalisation, reference point)
    res = compare(dirs)
    (p,) = res.problems
    for g in p.groups:
        mine = t["hypervolume"][t["run"] == g.runs[0].name]
        np.testing.assert_array_equal(mine, g.hv_curves[0])
        assert np.all(np.diff(mine) >= 0)  # never falls


def test_tidy_leaves_hypervolume_out_above_the_objective_limit(zdt1_runs, monkeypatch):
    # the exact volume's cost grows fast with the objectives (a 40-objective run never
    # finished): above the limit tidy's column is NaN, as compare's curves are absent
    import suspenv.analysis.load as load_module

    dirs = zdt1_runs["nsga2"][:1]
    assert np.isfinite(tidy(dirs)["hypervolume"]).all()
    monkeypatch.setattr(load_module, "HV_MAX_OBJECTIVES", 1)
    assert np.isnan(tidy(dirs)["hypervolume"]).all()


def test_cli_prints_the_hash_column_and_refusals_as_one_line(sphere_runs, tmp_path, capsys):
    dirs = [str(d) for d in sphere_runs["cmaes6"] + sphere_runs["cmaes12"]]
    assert main(["compare", *dirs, "--out", str(tmp_path / "c"), "--no-plots"]) == 0
    out = capsys.readouterr().out
    assert "hash" in out.splitlines()[1] and "popsize=6" in out and "popsize=12" in out
    assert "not separable with 3 and 3 seeds" in out
    bad = [str(d) for d in sphere_runs["random"] + sphere_runs["dim5"]]
    assert main(["compare", *bad, "--out", str(tmp_path / "d"), "--no-plots"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "options.dim: 4 -> 5" in err
