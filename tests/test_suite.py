"""The benchmark suite: instance cards, known optima and targets, reference fronts.

References: Sphere's closed form (minimum 0 at x = 0.3); the planar target geometry's own
hard points (curve error 0 by construction); the K&C truth without concealed effects (the
reference vehicle); ZDT1's analytic front; shipped fronts re-evaluated from their stored
designs (a front goes stale when a model changes: this test then fails).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.core.pareto import nondominated
from suspenv.registry import make_problem
from suspenv.suite.fronts import FRONT_DIR, load_front, thin
from suspenv.suite.instances import FUNCTIONS, build, parse_instance, selection
from suspenv.suite.runner import SUITE_FILE, run_suite


@pytest.mark.parametrize("name", ["sphere-10d", "zdt1-6d", "planar-curves", "carside", "minibus"])
def test_cards_state_what_the_problem_is(name):
    inst = build(name)
    card = inst.describe()
    p = make_problem(FUNCTIONS[name].problem, **FUNCTIONS[name].options_for(1))
    assert card["dimension"] == p.space.dim
    assert card["objectives"] == len(p.objective_names)
    assert card["constraints"] == len(p.constraint_names)
    assert card["budget"] == FUNCTIONS[name].budget > 0
    json.dumps(card)  # plain data


def test_sphere_optimum_is_the_closed_form():
    inst = build("sphere-10d")
    assert inst.known.kind == "optimum" and inst.known.f == 0.0
    x = np.array(inst.known.x)
    np.testing.assert_array_equal(x, np.full(10, 0.3))
    # and it is a minimum: every coordinate step raises f
    p = inst.problem
    f0 = p.evaluate(x[None, :]).objectives[0, 0]
    for j in range(10):
        for step in (-1e-3, 1e-3):
            y = x.copy()
            y[j] += step
            assert p.evaluate(y[None, :]).objectives[0, 0] > f0


def test_planar_and_kc_exact_optima_are_zero_at_the_stated_design():
    for name in ("planar-curves", "kc-exact"):
        inst = build(name)
        b = inst.problem.evaluate(np.array(inst.known.x)[None, :])
        assert b.ok[0] and np.all(b.objectives == 0.0), name


def test_kc_targets_are_the_truths_quality_and_vary_by_instance():
    values = []
    for i in (1, 2):
        inst = build("kc-tolerance", i)
        p = inst.problem
        f = float(p.quality(p.evaluate(p.truth_design()[None, :]).objectives)[0])
        assert inst.known.kind == "target" and inst.known.f == pytest.approx(f, rel=1e-12)
        values.append(f)
    assert values[0] != values[1]  # instances differ by the truth's seed
    # the same car with sensor noise: another measurement, another truth's quality (the
    # noise adds about one standard error to each mismatch, up or down)
    noisy = build("kc-noisy", 1)
    assert noisy.function.noisy and noisy.known.f != build("kc-tolerance", 1).known.f


def test_instance_names_and_errors():
    assert parse_instance("kc-noisy/i3") == ("kc-noisy", 3)
    assert ("kc-noisy", 3) in selection(["kc-noisy/i3"])
    assert len(selection(["kc-noisy"])) == 5
    with pytest.raises(ValidationError, match="did you mean 'kc-noisy'"):
        selection(["kc-noisey"])
    with pytest.raises(ValidationError, match="has instances"):
        selection(["kc-noisy/i9"])
    with pytest.raises(ValidationError, match="NAME/iN"):
        parse_instance("kc-noisy/3")


def test_zdt1_front_is_analytic():
    f = load_front("zdt1")
    np.testing.assert_allclose(f.points[:, 1], 1 - np.sqrt(f.points[:, 0]))
    assert nondominated(f.points).all()


@pytest.mark.parametrize("name", ["carside", "minibus"])
def test_shipped_fronts_are_reproduced_by_their_designs(name):
    if not (FRONT_DIR / f"{name}.json").is_file():
        pytest.fail(f"reference front {name} is not shipped")
    front = load_front(name)
    assert front.designs is not None and len(front.designs) == len(front.points)
    assert nondominated(front.points).all()
    p = build(name).problem
    assert front.objectives == tuple(p.objective_names)
    rows = np.random.default_rng(0).choice(len(front.points), 20, replace=False)
    batch = p.evaluate(front.designs[rows])
    assert batch.feasible.all()
    np.testing.assert_allclose(batch.objectives, front.points[rows], rtol=1e-9, atol=1e-12)
    assert "command" in front.provenance and front.provenance["budget_per_seed"] > 0


def test_thinning_keeps_the_extremes_and_spreads_evenly():
    f1 = np.linspace(0, 1, 1001)
    F = np.column_stack([f1, 1 - np.sqrt(f1)])
    idx = thin(F, 11)
    assert len(idx) == 11 and 0 in idx and 1000 in idx
    assert np.all(np.diff(F[idx, 0]) > 0.03)  # no two chosen points bunched together


def test_a_suite_run_writes_ordinary_run_directories(tmp_path):
    result = run_suite(
        ["random"],
        [1, 2],
        tmp_path,
        functions=["sphere-10d"],
        budget_scale=0.05,
        progress=False,
    )
    listed = json.loads((tmp_path / SUITE_FILE).read_text())
    assert listed == json.loads(json.dumps(result))
    assert len(result["runs"]) == 2
    for run in result["runs"]:
        summary = json.loads((Path(run["run_dir"]) / "summary.json").read_text())
        assert summary["n_evaluations"] == run["budget"] == 100
    with pytest.raises(ValidationError, match="budget_scale"):
        run_suite(["random"], [1], tmp_path, budget_scale=0.0, progress=False)


def test_plugins_run_from_a_config_and_from_a_suite_run(tmp_path, monkeypatch, capsys):
    from suspenv.analysis import compare
    from suspenv.cli.main import main

    # the user's layout: a project folder with strategies/centre.py, paths relative to it
    root = Path(__file__).parents[1]
    monkeypatch.chdir(root)
    name = "strategies/centre.py:Centre"
    cfg = tmp_path / "centre.toml"
    cfg.write_text(
        f'name = "centre"\nseed = 1\nbudget = 8\n[problem]\nname = "Sphere"\n'
        f'[strategy]\nname = "{name}"\n[run]\noutput = "{tmp_path / "runs"}"\n'
        "plots = false\nprogress = false\n"
    )
    # a config names code only when the user allows it
    assert main(["run", str(cfg)]) != 0
    assert "--allow-code" in capsys.readouterr().err
    assert main(["run", str(cfg), "--allow-code"]) == 0
    summary = json.loads((tmp_path / "runs" / "centre-seed1" / "summary.json").read_text())
    assert summary["strategy"] == name and summary["n_evaluations"] == 8
    # the command line names it directly
    result = run_suite(
        [name, "random"],
        [1, 2],
        tmp_path / "suite",
        ["sphere-10d"],
        budget_scale=0.05,
        progress=False,
    )
    dirs = [Path(r["run_dir"]).name for r in result["runs"]]
    assert "sphere-10d-i1-centre-Centre-seed1" in dirs
    labels = {
        g.label.split("[")[0]
        for g in compare([r["run_dir"] for r in result["runs"]]).problems[0].groups
    }
    assert labels == {name, "random"}


def test_seed_plan_says_before_running_whether_the_seeds_can_separate():
    from suspenv.analysis.stats import min_holm_p, rank_tests, seed_plan

    # the report: 6 strategies x 5 seeds; the floor by hand: 15 pairs x 2 / C(10, 5)
    assert min_holm_p(6, 5) == pytest.approx(15 * 2 / 252)
    seeds, note = seed_plan(6, [1, 2, 3, 4, 5])
    assert seeds == [1, 2, 3, 4, 5]
    assert "0.119 >= alpha 0.05" in note and "6 seeds are needed" in note
    # chosen: the fewest that can (15 x 2 / C(12, 6) = 0.0325 < 0.05), never below 5
    assert seed_plan(6, None)[0] == [1, 2, 3, 4, 5, 6]
    assert seed_plan(2, None)[0] == [1, 2, 3, 4, 5]
    assert "one strategy" in seed_plan(1, None)[1]
    # the floor is what rank_tests reaches with complete separation: 6 groups, 6 seeds
    samples = {f"s{g}": [10.0 * g + k for k in range(6)] for g in range(6)}
    pairs = rank_tests(samples)["pairs"]
    assert min(p["p_holm"] for p in pairs) == pytest.approx(min_holm_p(6, 6))
    assert all("better" in p["verdict"] for p in pairs)


def test_suite_run_refuses_repeated_seeds_and_too_short_budgets(tmp_path, capsys):
    from suspenv.cli.main import main

    with pytest.raises(ValidationError, match=r"seeds of a suite run must be distinct.*\[1, 1\]"):
        run_suite(["random"], [1, 1], tmp_path, progress=False)
    with pytest.raises(ValidationError, match=r"kc-exact/i1 22 evaluations for 49 variables"):
        run_suite(
            ["random"], [1], tmp_path, functions=["kc-exact"], budget_scale=0.01, progress=False
        )
    # the command line: a named error, no traceback, nothing run
    assert (
        main(
            ["suite", "run", "--strategies", "random", "--seeds", "1", "1", "--out", str(tmp_path)]
        )
        != 0
    )
    assert "must be distinct" in capsys.readouterr().err
    assert not (tmp_path / SUITE_FILE).exists()
