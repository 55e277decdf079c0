"""Every command on edge inputs gives a result or a named error (never a traceback): one
run, one seed, every run failed, a run still going, option values out of range, and
``from suspenv import *``."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from suspenv.cli.main import main
from suspenv.runs.config import validate
from suspenv.runs.runner import run_experiment


@pytest.fixture(scope="module")
def one_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("edge")
    cfg = validate(
        {
            "name": "one",
            "seed": 1,
            "budget": 100,
            "problem": {"name": "Sphere", "options": {"dim": 3}},
            "strategy": {"name": "random"},
            "run": {"output": str(out), "plots": False, "progress": False},
        }
    )
    return run_experiment(cfg)[0]


def _failed_copy(src: Path, dst: Path) -> Path:
    """The run as if every evaluation had failed (no feasible value)."""
    shutil.copytree(src, dst)
    s = json.loads((dst / "summary.json").read_text())
    s["quality_curve"] = [None] * len(s["quality_curve"])
    s["best_quality"] = None
    (dst / "summary.json").write_text(json.dumps(s))
    return dst


def test_compare_one_run_with_figures(one_run, tmp_path, capsys):
    assert main(["compare", str(one_run), "--out", str(tmp_path)]) == 0
    assert "single run" in capsys.readouterr().out
    assert (tmp_path / "fixed_target.png").stat().st_size > 1000


def test_compare_runs_that_all_failed(one_run, tmp_path, capsys):
    # the report: matplotlib's "Data cannot be log-scaled" traceback (no target reached)
    a = _failed_copy(one_run, tmp_path / "a")
    assert main(["compare", str(a), "--out", str(tmp_path / "c")]) == 0
    assert "no feasible evaluation" in capsys.readouterr().out
    result = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert result["problems"][0]["targets"] == []


def test_compare_a_run_still_going_is_a_named_error(one_run, tmp_path, capsys):
    going = tmp_path / "going"
    shutil.copytree(one_run, going)
    (going / "summary.json").unlink()  # what a run directory holds before it ends
    assert main(["compare", str(going), "--out", str(tmp_path / "c")]) != 0
    assert "not a finished run directory" in capsys.readouterr().err


@pytest.mark.parametrize(
    "option, message",
    [
        (["--f-opt", "nan"], "`f_opt` must be a finite number, but got f_opt=nan"),
        (["--f-opt", "inf"], "`f_opt` must be a finite number, but got f_opt=inf"),
        (["--n-targets", "0"], "`n_targets >= 1` must hold, but got n_targets=0"),
        (["--alpha", "1.5"], "`0 < alpha < 1` must hold, but got alpha=1.5"),
    ],
)
def test_compare_option_ranges_checked_before_any_work(one_run, tmp_path, capsys, option, message):
    out = tmp_path / "c"
    assert main(["compare", str(one_run), "--out", str(out), *option]) != 0
    assert message in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    "option, message",
    [
        (["--seeds", "1", "1"], "seeds of a suite run must be distinct"),
        (["--seeds", "1", "--budget-scale", "0.01"], "at least 10 evaluations per variable"),
        (["--seeds", "1", "--budget-scale", "nan"], "`0 < budget_scale <= 10`"),
    ],
)
def test_suite_run_option_ranges_checked_before_any_run(tmp_path, capsys, option, message):
    args = ["suite", "run", "--strategies", "random", "--out", str(tmp_path / "s"), *option]
    assert main(args) != 0
    assert message in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


def test_one_seed_suite_run_compares(tmp_path, capsys):
    args = [
        "suite",
        "run",
        "--strategies",
        "random",
        "cmaes",
        "--seeds",
        "1",
        "--functions",
        "sphere-10d",
        "--budget-scale",
        "0.05",
        "--quiet",
        "--out",
        str(tmp_path / "s"),
    ]
    assert main(args) == 0
    assert "no pair can be told apart; 4 seeds are needed" in capsys.readouterr().out
    assert main(["compare", str(tmp_path / "s"), "--out", str(tmp_path / "c"), "--no-plots"]) == 0
    assert "not separable with 1 and 1 seeds" in capsys.readouterr().out


def test_import_star_gives_every_name_of_all():
    code = (
        "from suspenv import *; import suspenv; names = dir(); "
        "print(all(n in names for n in suspenv.__all__))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"
