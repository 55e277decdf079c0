"""What a run writes and how it resumes: resolved configs, versions, figures, optuna storages.

Reports reproduced here:
* "defaults filled in by the code are not in the resolved config" and "versions.json ...
  leaves out" packages that ran;
* "A default optimize run on the 40-objective K&C problem spends 94 s and 1.6 GB drawing a
  10400 x 10400 px pair plot, with no progress shown";
* "re-running a config with an optuna storage silently continues the earlier study".
"""

from __future__ import annotations

import io
import json
import struct
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import optuna
import pytest

import suspenv.runs.optimize_pipeline as pipeline
from suspenv.core.errors import ValidationError
from suspenv.core.options import option_names
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.core.space import DesignSpace, Parameter
from suspenv.core.tomlfile import dump_toml
from suspenv.registry import (
    list_problems,
    list_strategies,
    make_problem,
    make_strategy,
    strategy_class,
)
from suspenv.reports import run as figures
from suspenv.runs.archive import RunArchive
from suspenv.runs.config import load_config, validate
from suspenv.runs.loop import optimize
from suspenv.runs.optimize_pipeline import FigureProgress, check_optimize_config
from suspenv.runs.runner import run_experiment
from suspenv.runs.versions import imported_distributions, package_versions, source_commit
from suspenv.strategies.nsga2 import RUN_KEY

RESERVED = ("dim", "n_objectives", "n_constraints", "seed")

CONFIG = """
seed = 1
budget = {budget}
[problem]
name = "ZDT1"
[strategy]
name = "{strategy}"
options = {options}
[run]
output = "{out}"
progress = {progress}
plots = {plots}
"""


def write(
    tmp_path, name="exp", strategy="random", options="{}", budget=100, plots=False, progress=False
) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(
        CONFIG.format(
            strategy=strategy,
            options=options,
            budget=budget,
            out=tmp_path / "runs",
            plots=str(plots).lower(),
            progress=str(progress).lower(),
        )
    )
    return path


def build(name: str, problem, **options):
    """A strategy, or skip when its optional package is not installed."""
    try:
        return make_strategy(name, problem, seed=1, **options)
    except ValidationError as exc:
        if "optional package" in str(exc):
            pytest.skip(str(exc))
        raise


# ------------------------------------------------------------- resolved configs
@pytest.mark.parametrize("strategy", ["cmaes", "nsga2", "pymoo_nsga2", "random", "lhs"])
def test_resolved_config_holds_every_default_and_reruns_as_the_same_experiment(tmp_path, strategy):
    run_dir, first = run_experiment(load_config(write(tmp_path, strategy=strategy)))
    resolved = tomllib.loads((run_dir / "config.resolved.toml").read_text())
    problem = make_problem("ZDT1")
    used = build(strategy, problem).options()
    assert resolved["problem"]["options"] == {"dim": 6}  # the default, written out
    assert resolved["strategy"]["options"] == {k: v for k, v in used.items() if v is not None}
    # the resolved config, run as a config, is the same experiment: it resumes
    _, again = run_experiment(load_config(run_dir / "config.resolved.toml"))
    assert again["n_evaluations"] == first["n_evaluations"] > 0
    assert again["n_resumed"] == again["n_evaluations"]  # 0 new evaluations
    assert again["front_size"] == first["front_size"] > 0  # ZDT1: a front, no scalar best


@pytest.mark.parametrize("name", list_problems())
def test_every_problem_default_options_round_trip_through_the_resolved_config(name):
    config = validate(
        {"name": "rt", "budget": 10, "problem": {"name": name}, "strategy": {"name": "random"}}
    )
    out = check_optimize_config(config)
    options = out["problem"]["options"]
    assert options, f"{name}: no default written"
    assert make_problem(name, **options).config() == make_problem(name).config()
    # written and read back, the resolved config resolves to itself
    back = tomllib.loads(dump_toml(out))
    assert check_optimize_config(validate(back))["problem"] == back["problem"]


@pytest.mark.parametrize("name", list_strategies())
def test_every_strategy_options_are_accepted_by_its_constructor(name):
    problem = make_problem("ZDT1")
    options = build(name, problem).options()
    accepted = option_names(strategy_class(name), RESERVED)
    assert accepted is None or set(options) <= set(accepted), set(options) - set(accepted or ())
    assert build(name, problem, **options).options() == options


# ----------------------------------------------------------------- versions
def test_versions_record_packages_imported_during_the_run():
    code = (
        "import json, colorlog\n"
        "from suspenv.runs.versions import package_versions\n"
        "print(json.dumps([package_versions(), package_versions(imported=True)]))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    declared, ran = json.loads(done.stdout)
    assert "colorlog" not in declared  # not declared by suspenv ...
    assert "colorlog" in ran  # ... but it ran
    assert {k: ran[k] for k in declared} == declared
    assert set(imported_distributions(["numpy.linalg", "os", "json"])) == {"numpy"}


def test_versions_json_of_a_run_names_what_ran_and_the_commit(tmp_path):
    run_dir, _ = run_experiment(load_config(write(tmp_path, strategy="pymoo_nsga2")))
    versions = json.loads((run_dir / "versions.json").read_text())
    assert versions["pymoo"] and versions["numpy"] and versions["suspenv"]
    assert set(imported_distributions()) <= set(versions) | {"suspenv"}
    if source_commit() is not None:
        assert versions["suspenv_commit"] == source_commit()
    with RunArchive(run_dir) as archive:
        assert archive.meta()["versions"] == versions
    assert package_versions(imported=True).keys() >= versions.keys() - {"suspenv_commit"}


# ------------------------------------------------------------------ figures
def png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    return struct.unpack(">II", head[16:24])


def test_many_objectives_get_a_readable_pair_plot_and_a_note(tmp_path, monkeypatch):
    # the rules at small sizes (same code path as 40 objectives x 5000+ evaluations)
    monkeypatch.setattr(figures, "MAX_PAIR_OBJECTIVES", 3)
    monkeypatch.setattr(figures, "MAX_POINTS", 50)
    rng = np.random.default_rng(0)
    F = rng.lognormal(size=(120, 6))
    F[:, 4] *= 1e-6  # spread does not depend on units
    F[:, 2] = 5.0 + 1e-3 * F[:, 2]  # a nearly constant objective is not shown
    notes: list[str] = []
    said: list[str] = []
    names = [f"f{j}" for j in range(6)]
    paths = figures.write_run_figures(F, np.ones(120, bool), names, tmp_path, said.append, notes)
    assert [p.name for p in paths] == ["convergence.png", "pareto_pairs.png", "pareto_parallel.png"]
    assert figures.pair_objectives(F) != [0, 1, 2] and 2 not in figures.pair_objectives(F)
    assert any("shows 3 of the 6 objectives" in n and "36 panels" in n for n in notes)
    assert any("pareto_pairs.png draws 50 of the 120 feasible" in n for n in notes)
    assert said[0].startswith("convergence.png") and said[1].startswith("pareto_pairs.png (3 x 3")
    assert png_size(tmp_path / "pareto_pairs.png") == (780, 780)  # 3 x 3 panels of 260 px


def test_default_figures_above_eight_objectives_stay_small(tmp_path):
    rng = np.random.default_rng(1)
    F = rng.lognormal(size=(200, 12))
    notes: list[str] = []
    figures.write_run_figures(
        F, np.ones(200, bool), [f"g{j}" for j in range(12)], tmp_path, notes=notes
    )
    sizes = {p.name: png_size(p) for p in tmp_path.glob("*.png")}
    assert sizes["pareto_pairs.png"] == (2080, 2080)  # 8 x 8, not 12 x 12 (3120 px)
    assert all(max(s) <= figures.MAX_PIXELS for s in sizes.values()), sizes
    assert sizes["convergence.png"][1] < sizes["convergence.png"][0]  # a grid, 2 rows
    assert len(notes) == 1 and "8 of the 12 objectives" in notes[0]
    once, twice = figures.subsample(np.arange(10), 5), figures.subsample(np.arange(10), 5)
    assert once.tolist() == twice.tolist() and len(set(once.tolist())) == 5  # seeded


def test_progress_is_shown_only_when_drawing_takes_long():
    quiet = io.StringIO()
    p = FigureProgress(after_s=60, stream=quiet)
    p("convergence.png")
    p.close()
    assert quiet.getvalue() == ""
    late = io.StringIO()
    p = FigureProgress(after_s=0.05, stream=late)
    p("pareto_pairs.png (8 x 8 panels)")  # one long drawing: the timer names it
    time.sleep(0.5)
    p("pareto_parallel.png")  # after that, each step at once
    p.close()
    lines = late.getvalue().splitlines()
    assert lines[0].startswith("suspenv: drawing pareto_pairs.png (8 x 8 panels)")
    assert lines[1].startswith("suspenv: drawing pareto_parallel.png")
    assert lines[2].startswith("suspenv: figures done")
    off = io.StringIO()
    p = FigureProgress(after_s=0, stream=off, on=False)
    p("x")
    p.close()
    assert off.getvalue() == ""


def test_a_run_prints_what_it_draws_and_notes_what_it_left_out(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(pipeline, "PROGRESS_AFTER_S", 0.0)
    monkeypatch.setattr(figures, "MAX_POINTS", 30)
    _, summary = run_experiment(load_config(write(tmp_path, plots=True, progress=True)))
    err = capsys.readouterr().err
    assert "suspenv: drawing convergence.png (2 panels, 100 evaluations)" in err
    assert "suspenv: drawing pareto_pairs.png" in err
    assert summary["figure_notes"] == [
        "pareto_pairs.png draws 30 of the 100 feasible evaluations (seeded subsample, "
        "numpy.random.default_rng(0)); the non-dominated set is computed from all feasible "
        "evaluations"
    ]


# ----------------------------------------------------------- optuna storages
def nsga2_config(tmp_path, name="a", extra=""):
    db = tmp_path / "study.db"
    options = f'{{ population_size = 8, storage = "sqlite:///{db}"{extra} }}'
    return write(tmp_path, name=name, strategy="nsga2", options=options, budget=16), db


def trials_of(db: Path, study="suspenv-nsga2-1"):
    return optuna.load_study(study_name=study, storage=f"sqlite:///{db}").get_trials()


def test_rerunning_a_config_with_a_storage_into_a_new_run_is_refused(tmp_path):
    first, db = nsga2_config(tmp_path, "a")
    run_experiment(load_config(first))
    second, _ = nsga2_config(tmp_path, "b")  # another run directory, the same study
    with pytest.raises(ValidationError) as err:
        run_experiment(load_config(second))
    message = str(err.value)
    assert f"'sqlite:///{db}'" in message and "study 'suspenv-nsga2-1'" in message
    assert "16 trials of another run" in message and "strategy.options.resume = true" in message
    assert not (tmp_path / "runs" / "b-seed1").exists()  # refused by the config check
    assert len(trials_of(db)) == 16
    # --overwrite empties the run directory: its old trials are another run's now
    with pytest.raises(ValidationError, match="resume = false"):
        run_experiment(load_config(first), overwrite=True)


def test_resume_true_continues_the_study(tmp_path):
    first, db = nsga2_config(tmp_path, "a")
    run_experiment(load_config(first))
    second, _ = nsga2_config(tmp_path, "b", ", resume = true")
    _, summary = run_experiment(load_config(second))
    assert summary["n_evaluations"] == 16 and summary["n_resumed"] == 0
    trials = trials_of(db)
    assert len(trials) == 32 and all(t.state.is_finished() for t in trials)
    runs = {t.user_attrs[RUN_KEY][0] for t in trials}
    assert len(runs) == 2


def test_resuming_a_run_directory_replays_its_own_trials(tmp_path):
    path, db = nsga2_config(tmp_path, "a")
    _, first = run_experiment(load_config(path))
    _, again = run_experiment(load_config(path))  # suspenv's own resume: not refused
    assert again["n_resumed"] == again["n_evaluations"] == 16
    assert again["front_size"] == first["front_size"] > 0  # ZDT1: a front, no scalar best
    assert len(trials_of(db)) == 16  # nothing added twice


def test_building_or_checking_the_strategy_creates_no_study(tmp_path):
    db = tmp_path / "lazy.db"
    problem = make_problem("ZDT1")
    s = make_strategy("nsga2", problem, seed=1, population_size=6, storage=f"sqlite:///{db}")
    s.check_storage()
    assert not db.exists()
    config = validate(
        {
            "name": "lazy",
            "budget": 12,
            "problem": {"name": "ZDT1"},
            "strategy": {
                "name": "nsga2",
                "options": {"population_size": 6, "storage": f"sqlite:///{db}"},
            },
            "run": {"output": str(tmp_path / "runs")},
        }
    )
    check_optimize_config(config)
    assert not db.exists()
    s.ask()  # the study is made on the first ask
    assert len(trials_of(db)) == 6


def test_a_run_that_stopped_between_ask_and_tell_is_replayed(tmp_path):
    db = tmp_path / "crash.db"
    problem = make_problem("ZDT1")

    def strategy(run_id):
        s = make_strategy("nsga2", problem, seed=3, population_size=8, storage=f"sqlite:///{db}")
        s.bind_run(run_id)
        return s

    U1 = strategy("r1").ask()  # the process dies before the tell
    s = strategy("r1")
    U2 = s.ask()
    np.testing.assert_array_equal(U1, U2)  # the stored trials, served again
    s.tell(U2, problem.evaluate_unit(U2))
    trials = trials_of(db, "suspenv-nsga2-3")
    assert len(trials) == 8 and all(t.state == optuna.trial.TrialState.COMPLETE for t in trials)
    with pytest.raises(ValidationError, match="8 trials of another run"):
        strategy("r2").ask()


def test_a_partial_run_resumes_through_the_loop_with_a_storage(tmp_path):
    db = tmp_path / "loop.db"
    problem = make_problem("ZDT1")

    def strategy():
        s = make_strategy("nsga2", problem, seed=2, population_size=8, storage=f"sqlite:///{db}")
        s.bind_run("run-1")
        return s

    optimize(problem, strategy(), 16, run_dir=tmp_path / "r")
    result = optimize(problem, strategy(), 40, run_dir=tmp_path / "r")
    assert result.n_resumed == 16 and result.n_evaluations == 40
    trials = trials_of(db, "suspenv-nsga2-2")
    assert len(trials) == 40 and all(t.state.is_finished() for t in trials)
    with RunArchive(tmp_path / "r") as archive:
        U = archive.arrays()["unit"]
    stored = np.array([[t.params[f"u{i}"] for i in range(6)] for t in trials])
    np.testing.assert_array_equal(stored, U)


class LogAndShifted(Problem):
    """Two physical variables, one on a log scale, two named objectives (a test problem)."""

    name = "LogAndShifted"

    def __init__(self):
        self.space = DesignSpace(
            [
                Parameter("stiffness", 10.0, 1000.0, unit="N/mm", log=True),
                Parameter("offset", -5.0, 3.0, unit="mm"),
            ]
        )
        self.objective_names = ("compliance", "offset_error")

    def _evaluate(self, X):
        F = np.column_stack([1.0 / X[:, 0], np.abs(X[:, 1] - 1.0)])
        n = len(X)
        return EvaluationBatch(F, np.zeros((n, 0)), np.ones(n, bool), [""] * n)


@pytest.mark.parametrize("name", ["nsga2", "optuna_tpe", "optuna_nsga3"])
def test_a_bound_optuna_study_holds_the_physical_design_and_metric_names(name):
    # reference: the problem's DesignSpace (names, bounds, log flag) and its
    # to_physical map, against what optuna's study stores for each asked trial
    problem = LogAndShifted()
    options = {"population_size": 4} if name != "optuna_tpe" else {"batch_size": 4}
    s = make_strategy(name, problem, seed=3, **options)
    s.bind_problem(problem)
    U = s.ask()
    s.tell(U, problem.evaluate_unit(U))
    assert s.study.metric_names == ["compliance", "offset_error"]
    trials = s.study.get_trials()
    assert len(trials) == 4
    want = {
        "stiffness": optuna.distributions.FloatDistribution(10.0, 1000.0, log=True),
        "offset": optuna.distributions.FloatDistribution(-5.0, 3.0),
    }
    X = np.array([[t.params["stiffness"], t.params["offset"]] for t in trials])
    assert all(t.distributions == want for t in trials)
    np.testing.assert_allclose(problem.space.to_physical(U), X, rtol=1e-12, atol=1e-12)


def test_the_live_study_of_an_nsga2_run_is_named_after_the_problem(tmp_path):
    db = tmp_path / "named.db"
    problem = make_problem("MinibusRideHandling")
    path = write(
        tmp_path,
        name="named",
        strategy="nsga2",
        options=f'{{ population_size = 4, storage = "sqlite:///{db}" }}',
        budget=4,
    )
    path.write_text(path.read_text().replace('name = "ZDT1"', 'name = "MinibusRideHandling"'))
    run_dir, _ = run_experiment(load_config(path))
    study = optuna.load_study(study_name="suspenv-nsga2-1", storage=f"sqlite:///{db}")
    assert study.metric_names == list(problem.objective_names)
    names = list(problem.space.names)
    for t in study.get_trials():
        assert list(t.params) == names
        for p in problem.space.parameters:
            assert t.distributions[p.name] == optuna.distributions.FloatDistribution(
                p.low, p.high, log=p.log
            )
    with RunArchive(run_dir) as archive:
        X = archive.arrays()["x"]
    stored = np.array([[t.params[n] for n in names] for t in study.get_trials()])
    np.testing.assert_allclose(stored, X, rtol=1e-12)


def test_polylines_draw_every_row_through_its_values_as_one_artist():
    # reference: the definition of a parallel-coordinate line (row k passes through
    # (j, values[k, j])), read back from the drawn collection
    from suspenv.reports._mpl import add_polylines, pyplot

    plt = pyplot()
    values = np.array([[0.0, 1.0, 0.5], [2.0, -1.0, 0.25]])
    fig, ax = plt.subplots()
    try:
        lines = add_polylines(ax, values, colors="k", lw=0.5)
        assert len(ax.collections) == 1 and not ax.lines
        drawn = [np.asarray(p) for p in lines.get_segments()]
        assert len(drawn) == 2
        for row, seg in zip(values, drawn, strict=True):
            assert np.array_equal(seg[:, 0], [0.0, 1.0, 2.0])
            assert np.array_equal(seg[:, 1], row)
        lo, hi = ax.get_ylim()
        assert lo <= -1.0 and hi >= 2.0  # the axes take the lines in
    finally:
        plt.close(fig)
