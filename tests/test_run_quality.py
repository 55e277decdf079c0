"""One definition of "best" (suspenv.runs.quality): its golden values, and every reader of
a run (the loop, the summary, ``suspenv show``, ``tidy``, ``compare``) following it.

Reports reproduced here: the run summary's "best sum of objectives" added m/s^2 to
degrees; the loop picked its best row by the mean of the objectives; ``tidy``'s
``best_so_far`` of a multi-objective run was the sum of its objectives.
"""

from __future__ import annotations

import itertools

import numpy as np

from suspenv.analysis.load import runs_table, tidy
from suspenv.cli.show import format_summary
from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.registry import make_problem, make_strategy
from suspenv.runs import quality
from suspenv.runs.archive import RunArchive
from suspenv.runs.loop import optimize
from suspenv.runs.runner import run_experiment


class Constrained(Problem):
    """f = x + y, feasible when x >= 0.5 (g = 0.5 - x <= 0): the best feasible row is not
    the least f of all rows."""

    name = "Constrained"

    def __init__(self):
        self.space = DesignSpace([Parameter("x", 0.0, 1.0), Parameter("y", 0.0, 1.0)])
        self.objective_names = ("f",)
        self.constraint_names = ("x_min",)

    def _evaluate(self, X):
        n = len(X)
        return EvaluationBatch(
            X.sum(1, keepdims=True), (0.5 - X[:, :1]), np.ones(n, bool), [""] * n
        )


def test_golden_feasibility_best_so_far_and_best_row():
    # reference: the definitions written out by hand for five rows
    ok = np.array([True, True, False, True, True])
    g = np.array([[0.1], [-1.0], [-1.0], [np.nan], [0.0]])
    feas = quality.feasible(ok, g)
    np.testing.assert_array_equal(feas, [False, True, False, False, True])
    q = np.array([0.5, 3.0, 1.0, 0.1, 2.0])
    np.testing.assert_array_equal(quality.best_so_far(q, feas), [np.inf, 3.0, 3.0, 3.0, 2.0])
    assert quality.best_row(q, feas) == 4
    assert quality.best_row(q, np.zeros(5, bool)) is None


def test_golden_best_so_far_without_feasibility_and_the_stored_curve():
    # reference: the definition written out by hand; NaN rows are skipped, +inf before
    # the first finite value, stored as None (JSON has no infinity)
    b = quality.best_so_far(np.array([np.nan, 3.0, 4.0, 1.0, np.nan, 2.0]))
    np.testing.assert_array_equal(b, [np.inf, 3.0, 3.0, 1.0, 1.0, 1.0])
    assert quality.curve_items(b) == {
        "best_quality": 1.0,
        "quality_curve": [None, 3.0, 3.0, 1.0, 1.0, 1.0],
    }
    none = quality.best_so_far(np.array([np.nan, 2.0]), np.array([True, False]))
    assert quality.curve_items(none) == {"best_quality": None, "quality_curve": [None, None]}
    assert quality.curve_items(quality.best_so_far(np.zeros(0))) == {
        "best_quality": None,
        "quality_curve": [],
    }


def test_several_objectives_have_no_scalar_quality_one_has_the_objective():
    zdt = make_problem("ZDT1")
    F = np.array([[0.2, 0.9], [0.4, 0.1]])
    assert quality.quality(zdt, F) is None
    sphere = make_problem("Sphere", dim=2)
    np.testing.assert_array_equal(quality.quality(sphere, [[1.5], [0.25]]), [1.5, 0.25])
    assert quality.scalar_recorded("objective", 1)
    assert not quality.scalar_recorded(None, 5)
    assert not quality.scalar_recorded("sum of objectives", 5)  # a run written before


def test_the_loop_best_is_the_least_feasible_objective(tmp_path):
    p = Constrained()
    r = optimize(p, make_strategy("random", p, seed=4, batch_size=16), 64, run_dir=tmp_path)
    with RunArchive(tmp_path) as a:
        arr = a.arrays()
    f, feas = arr["objectives"][:, 0], arr["constraints"][:, 0] <= 0
    assert feas.any() and (~feas).any() and f[~feas].min() < f[feas].min()
    assert r.best_index == int(np.flatnonzero(feas)[np.argmin(f[feas])])
    assert r.best_objectives == [float(f[feas].min())]


def _dominated(F: np.ndarray) -> np.ndarray:
    """Rows some other row dominates, by the definition (O(n^2), no library)."""
    out = np.zeros(len(F), bool)
    for i, j in itertools.permutations(range(len(F)), 2):
        if (F[j] <= F[i]).all() and (F[j] < F[i]).any():
            out[i] = True
    return out


def test_a_multiobjective_run_reports_its_front_and_no_best(tmp_path):
    config = {
        "name": "zdt",
        "seed": 2,
        "budget": 40,
        "problem": {"name": "ZDT1"},
        "strategy": {"name": "random", "options": {"batch_size": 20}},
        "run": {"output": str(tmp_path), "plots": False, "progress": False},
    }
    run_dir, s = run_experiment(config)
    assert s["quality_name"] is None and s["best_quality"] is None
    assert s["quality_curve"] is None and s["best_objectives"] is None
    with RunArchive(run_dir) as a:
        F = a.arrays()["objectives"]
    assert s["front_size"] == int((~_dominated(F)).sum()) > 0
    shown = format_summary(s)
    assert f"feasible front [designs]  {s['front_size']}" in shown and "best" not in shown
    t = tidy([run_dir])
    assert np.isnan(t["best_so_far"]).all() and np.isfinite(t["hypervolume"]).all()
    assert np.isnan(runs_table([run_dir])["best_quality"]).all()


def test_show_never_prints_a_recorded_sum_of_objectives():
    old = {
        "n_evaluations": 10,
        "objective_names": ["ride [m/s^2]", "roll [deg]"],
        "quality_name": "sum of objectives",
        "best_quality": 7.5,
        "best_objectives": [1.5, 6.0],
    }
    shown = format_summary(old)
    assert "7.5" not in shown and "best" not in shown


def test_evaluations_csv_and_tidy_name_their_columns_alike(tmp_path):
    # reference: the problem's own names and units, written out here
    config = {
        "name": "minibus",
        "seed": 1,
        "budget": 4,
        "problem": {"name": "MinibusRideHandling"},
        "strategy": {"name": "random", "options": {"batch_size": 4}},
        "run": {"output": str(tmp_path), "plots": False, "progress": False},
    }
    run_dir, _ = run_experiment(config)
    p = make_problem("MinibusRideHandling")
    header = (run_dir / "evaluations.csv").read_text().splitlines()[0].split(",")
    designs = [f"design:{q.name} [{q.unit or '-'}]" for q in p.space.parameters]
    objectives = [
        f"objective:{n} [{u}]" for n, u in zip(p.objective_names, p.objective_units, strict=True)
    ]
    constraints = [f"constraint:{n}" for n in p.constraint_names]
    values = [*designs, *objectives, *constraints]
    assert header == ["batch", "row", *values, "ok", "message", "wall_time [s]"]
    t = tidy([run_dir])
    assert [c for c in t if ":" in c] == values
