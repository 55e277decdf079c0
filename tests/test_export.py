"""``suspenv export optuna``: a run directory as an optuna study that optuna-dashboard reads.

Reported: "optuna-dashboard shows parameters as u0..u7 and unnamed objectives." The
export is read back with optuna itself (names, values, bounds, counts, states,
constraints, attributes); optuna-dashboard need not be installed.
"""

from __future__ import annotations

import re
import sqlite3

import numpy as np
import optuna
import pytest
from optuna.distributions import FloatDistribution
from optuna.trial import TrialState

import suspenv.registry as registry
from suspenv.cli.main import main
from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import ValidationError
from suspenv.runs.archive import RunArchive
from suspenv.runs.config import load_config
from suspenv.runs.export import DRIVERS, export_optuna, storage_url
from suspenv.runs.runner import run_experiment


class Bracket(Problem):
    """Two objectives in units, one constraint, a log-scale parameter; fails at x > 0.8."""

    name = "Bracket"

    def __init__(self, scale: float = 1.0):
        self.scale = scale
        self.space = DesignSpace(
            [
                Parameter("thickness", 1.0, 5.0, unit="mm"),
                Parameter("stiffness", 10.0, 1000.0, unit="N/mm", log=True),
                Parameter("x", 0.0, 1.0),
            ]
        )
        self.objective_names = ("mass", "deflection")
        self.objective_units = ("kg", "mm")
        self.constraint_names = ("stress_margin",)

    def _evaluate(self, X):
        ok = X[:, 2] <= 0.8
        F = np.c_[self.scale * X[:, 0], 100.0 / X[:, 1]]
        G = (X[:, 2] - 0.5)[:, None]
        msgs = ["" if o else "bracket buckles at x > 0.8" for o in ok]
        F = np.where(ok[:, None], F, np.nan)
        return EvaluationBatch(F, np.where(ok[:, None], G, np.nan), ok, msgs)

    def config(self):
        return {"scale": self.scale}


CONFIG = """
seed = 4
budget = 60
[problem]
name = "Bracket"
options = {{ scale = 2.0 }}
[strategy]
name = "random"
options = {{ batch_size = 20 }}
[run]
output = "{out}"
progress = false
plots = false
"""


@pytest.fixture
def run_dir(tmp_path, monkeypatch):
    monkeypatch.setitem(registry._PROBLEMS, "Bracket", Bracket)
    path = tmp_path / "bracket.toml"
    path.write_text(CONFIG.format(out=tmp_path / "runs"))
    run_dir, summary = run_experiment(load_config(path))
    assert 0 < summary["n_ok"] < 60  # some designs failed
    return run_dir


def test_export_names_parameters_and_objectives_and_keeps_every_evaluation(run_dir, tmp_path):
    url = f"sqlite:///{tmp_path / 'dash.db'}"
    result = export_optuna(run_dir, url)
    with RunArchive(run_dir) as archive:
        a = archive.arrays()
        meta = archive.meta()
    study = optuna.load_study(study_name="bracket-seed4", storage=url)
    assert result.study_name == "bracket-seed4" and result.bounds == "design space"
    assert study.metric_names == ["mass", "deflection"]
    assert study.directions == [optuna.study.StudyDirection.MINIMIZE] * 2
    trials = study.get_trials()
    assert len(trials) == len(a["ok"]) == 60
    assert [t.state for t in trials] == [
        TrialState.COMPLETE if ok else TrialState.FAIL for ok in a["ok"]
    ]
    assert result.n_complete == int(a["ok"].sum()) and result.n_failed == int((~a["ok"]).sum())
    bounds = {"thickness": (1.0, 5.0, False), "stiffness": (10.0, 1000.0, True), "x": (0, 1, False)}
    for i, t in enumerate(trials):
        assert list(t.params) == ["thickness", "stiffness", "x"]  # not u0, u1, u2
        np.testing.assert_allclose(list(t.params.values()), a["x"][i], rtol=1e-12)
        for name, (lo, hi, log) in bounds.items():
            assert t.distributions[name] == FloatDistribution(lo, hi, log=log)
        assert (t.user_attrs["batch"], t.user_attrs["row"]) == (a["batch"][i], a["row"][i])
        if a["ok"][i]:
            np.testing.assert_array_equal(t.values, a["objectives"][i])
            assert t.system_attrs["constraints"] == list(a["constraints"][i])
            assert t.values[0] == pytest.approx(2.0 * t.params["thickness"])  # scale = 2
        else:
            assert t.values is None and "buckles" in t.user_attrs["message"]
            assert "constraints" not in t.system_attrs
    attrs = study.user_attrs
    assert attrs["run"] == "bracket" and attrs["seed"] == 4
    assert attrs["problem"] == "Bracket" and attrs["problem_options"] == {"scale": 2.0}
    assert attrs["strategy"] == "random" and attrs["strategy_options"]["batch_size"] == 20
    assert attrs["constraint_names"] == ["stress_margin"]
    assert attrs["objective_units"] == ["kg", "mm"]
    assert attrs["parameter_units"] == ["mm", "N/mm", ""]
    assert attrs["suspenv_version"] == meta["versions"]["suspenv"]
    assert attrs.get("suspenv_commit") == meta["versions"].get("suspenv_commit")
    # optuna reads the constraints (feasible when <= 0) from the system attribute
    feasible = [t for t in trials if t.state == TrialState.COMPLETE and t.params["x"] <= 0.5]
    assert all(all(v <= 0 for v in t.constraints.values()) for t in feasible)


def test_an_existing_study_is_refused_unless_replaced(run_dir, tmp_path):
    url = f"sqlite:///{tmp_path / 'dash.db'}"
    export_optuna(run_dir, url, "bracket")
    with pytest.raises(ValidationError, match=r"already holds a study 'bracket'.*--replace"):
        export_optuna(run_dir, url, "bracket")
    again = export_optuna(run_dir, url, "bracket", replace=True)
    assert again.n_trials == 60
    assert len(optuna.load_study(study_name="bracket", storage=url).get_trials()) == 60


def test_cli_export_optuna(run_dir, tmp_path, capsys):
    db = tmp_path / "cli.db"
    code = main(["export", "optuna", str(run_dir), "--storage", str(db), "--study", "b"])
    assert code == 0
    out = capsys.readouterr().out
    assert "60 trials" in out and "optuna-dashboard sqlite:///" in out
    study = optuna.load_study(study_name="b", storage=storage_url(str(db)))
    assert study.metric_names == ["mass", "deflection"]
    assert main(["export", "optuna", str(tmp_path), "--storage", str(db)]) == 2  # no archive


def test_without_the_problem_the_bounds_are_the_observed_ranges(run_dir, tmp_path, monkeypatch):
    monkeypatch.delitem(registry._PROBLEMS, "Bracket")  # the problem is gone
    url = f"sqlite:///{tmp_path / 'obs.db'}"
    result = export_optuna(run_dir, url)
    study = optuna.load_study(study_name=result.study_name, storage=url)
    assert result.bounds == "observed" and study.user_attrs["bounds"] == "observed"
    with RunArchive(run_dir) as archive:
        x = archive.arrays()["x"]
    dist = study.get_trials()[0].distributions["thickness"]
    assert (dist.low, dist.high) == (x[:, 0].min(), x[:, 0].max())


@pytest.mark.parametrize(
    ("storage", "needle"),
    [
        ("foo://host/db", "unknown kind of database 'foo'"),
        ("http://localhost:8080/db", "unknown kind of database 'http'"),
        ("postgresql+nodriver://u@localhost/db", "unknown kind of database"),
        ("mysql+nosuchdriver://u@h/db", "unknown kind of database"),
        ("sqlite:///{tmp}/no/such/folder/x.db", "cannot be opened (unable to open database"),
        ("sqlite://", "in-memory database"),
        ("sqlite:///:memory:", "in-memory database"),
        ("postgresql://user@:bad:port/db", "is not a database URL"),
    ],
)
def test_a_bad_storage_url_is_named_before_anything_is_written(run_dir, tmp_path, storage, needle):
    with pytest.raises(ValidationError, match=re.escape(needle)):
        export_optuna(run_dir, storage.format(tmp=tmp_path))


@pytest.mark.parametrize("url", ["postgresql://u@localhost/db", "mysql://u@localhost/db"])
def test_a_missing_driver_is_named_with_its_package(run_dir, url):
    import sqlalchemy

    try:
        sqlalchemy.create_engine(url).dispose()
    except ImportError as exc:
        module = exc.name
    else:
        pytest.skip(f"the driver of {url} is installed")
    package = DRIVERS.get(str(module), module)
    with pytest.raises(
        ValidationError,
        match=re.escape(f"{module!r}, which is not installed: pip install {package}"),
    ):
        export_optuna(run_dir, url)


def test_the_runs_own_archive_and_other_databases_are_refused(run_dir, tmp_path):
    db = run_dir / "archive.sqlite"
    before = db.read_bytes()
    with pytest.raises(ValidationError, match="the run's own archive"):
        export_optuna(run_dir, str(db))
    with pytest.raises(ValidationError, match="the run's own archive"):
        export_optuna(run_dir, f"sqlite:///{db}")
    assert db.read_bytes() == before
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as con:
        con.execute("CREATE TABLE invoices (id INTEGER)")
    with pytest.raises(ValidationError, match=r"holds tables \(invoices\) but is not an optuna"):
        export_optuna(run_dir, str(other))
    with sqlite3.connect(other) as con:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    assert tables == {"invoices"}
