"""Strategies compared on the kept objectives (run directories readable by `suspenv compare`)."""

from __future__ import annotations

import json

import numpy as np
from synthetic_problem import SyntheticIdentification

from suspenv.methods.tey2014.identification import FixedRankSum
from suspenv.methods.tey2014.strategy_comparison import compare_strategies
from suspenv.problems.views import ObjectiveSubset
from suspenv.runs.archive import RunArchive


def test_compare_strategies_writes_runs_table_and_plot(tmp_path):
    base = SyntheticIdentification()
    problem = ObjectiveSubset(base, [0, 3, 6, 8])
    rng = np.random.default_rng(0)
    quality = FixedRankSum.fit(problem.evaluate_unit(rng.uniform(size=(50, 8))).objectives)
    result = compare_strategies(problem, ["random", "cmaes"], [1, 2], 84, quality, tmp_path)
    table = {r["strategy"]: r for r in result["table"]}
    assert set(table) == {"random", "cmaes"} and table["random"]["runs"] == 2
    assert (tmp_path / "compare.png").stat().st_size > 1000
    # each run's best quality, recomputed independently from its archive
    for run in result["runs"]:
        summary = json.loads((tmp_path / run / "summary.json").read_text())
        with RunArchive(tmp_path / run) as archive:
            a = archive.arrays()
        feasible = a["ok"] & (np.nan_to_num(a["constraints"], nan=1.0).max(axis=1) <= 0)
        q = quality(a["objectives"][feasible])
        assert summary["best_quality"] == np.min(q)
        assert summary["n_evaluations"] == 84
    best = [
        json.loads((tmp_path / r / "summary.json").read_text())["best_quality"]
        for r in result["runs"]
        if r.startswith("random")
    ]
    assert table["random"]["best_min"] == min(best) and table["random"]["best_max"] == max(best)


def test_objective_subset_keeps_columns_and_failures():
    base = SyntheticIdentification()
    sub = ObjectiveSubset(base, [8, 0])
    X = np.vstack([base.truth_design(), base.space.reference()])
    X[1, 7] = 0.99  # planted failure region
    full, part = base.evaluate(X), sub.evaluate(X)
    np.testing.assert_array_equal(part.objectives[0], full.objectives[0, [8, 0]])
    assert not part.ok[1] and part.messages[1] == full.messages[1]
    assert sub.objective_names == ("d_gradient", "a_gradient")


def test_with_signed_responses_appends_the_residual_extras():
    from suspenv.problems.toy import ZDT1
    from suspenv.problems.views import WithSignedResponses

    base = SyntheticIdentification()
    view = WithSignedResponses(base)
    X = np.vstack([base.space.reference(), base.truth_design()])
    b = view.evaluate(X)
    assert b.objectives.shape == (2, 20)
    np.testing.assert_allclose(b.objectives[:, 10:], base.residuals(X))
    np.testing.assert_allclose(np.abs(b.objectives[:, 10:]), b.objectives[:, :10])
    # a problem without signed extras gets NaN columns (the study then falls back)
    z = WithSignedResponses(ZDT1()).evaluate(np.full((1, 6), 0.5))
    assert np.isnan(z.objectives[0, 2:]).all() and np.isfinite(z.objectives[0, :2]).all()
