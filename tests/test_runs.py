"""Experiment configs, run directories, resume through the runner, show and compare."""

import json
import tomllib

import numpy as np
import pytest

from suspenv.cli.show import format_summary
from suspenv.core.errors import ValidationError
from suspenv.reports.analysis import write_comparison
from suspenv.runs.config import load_config, parse_override
from suspenv.runs.run_dir import load_summary
from suspenv.runs.runner import run_experiment

CONFIG = """
seed = 3
budget = 120
[problem]
name = "Sphere"
options = {{ dim = 4 }}
[strategy]
name = "{strategy}"
[run]
output = "{out}"
progress = false
"""


def _write(tmp_path, strategy="cmaes", name="exp"):
    path = tmp_path / f"{name}.toml"
    path.write_text(CONFIG.format(strategy=strategy, out=tmp_path / "runs"))
    return path


def test_run_writes_everything_and_same_seed_same_numbers(tmp_path):
    cfg = load_config(_write(tmp_path))
    run_dir, summary = run_experiment(cfg)
    for f in (
        "archive.sqlite",
        "evaluations.csv",
        "summary.json",
        "config.resolved.toml",
        "versions.json",
        "convergence.png",
    ):
        assert (run_dir / f).is_file(), f
    resolved = tomllib.loads((run_dir / "config.resolved.toml").read_text())
    assert resolved["seed"] == 3 and resolved["problem"]["options"]["dim"] == 4
    assert "numpy" in json.loads((run_dir / "versions.json").read_text())
    # re-running the same config resumes: nothing is evaluated again, same numbers
    _, again = run_experiment(cfg)
    assert again["n_resumed"] == summary["n_evaluations"] == 120
    assert again["best_objectives"] == summary["best_objectives"]
    assert "best objective" in format_summary(load_summary(run_dir))


def test_overrides_and_changed_config_refused(tmp_path):
    path = _write(tmp_path)
    cfg = load_config(path, ["strategy.options.popsize=6", "budget=60"])
    assert cfg["strategy"]["options"]["popsize"] == 6 and cfg["budget"] == 60
    run_experiment(cfg)
    other = load_config(path, ["strategy.options.popsize=8", "budget=60"])
    with pytest.raises(ValidationError, match=r"strategy.options.popsize: 6 -> 8"):
        run_experiment(other)
    run_dir, s = run_experiment(other, overwrite=True)
    assert s["n_resumed"] == 0


def test_results_of_another_commit_are_not_resumed(tmp_path):
    # a run folder whose versions.json names another suspenv commit holds results of
    # other code: resuming would mix two versions, so it is refused (and --overwrite works)
    cfg = load_config(_write(tmp_path), ["budget=24"])
    run_dir, _ = run_experiment(cfg)
    stored = json.loads((run_dir / "versions.json").read_text())
    stored["suspenv_commit"] = "0" * 40
    (run_dir / "versions.json").write_text(json.dumps(stored))
    with pytest.raises(ValidationError, match=r"holds results of suspenv 0{40}, but this is"):
        run_experiment(cfg)
    _, s = run_experiment(cfg, overwrite=True)
    assert s["n_resumed"] == 0


@pytest.mark.parametrize(
    ("override", "needle"),
    [
        ("seed=-1", "config: `seed >= 0` must hold, but got seed=-1"),
        ("budget=0", "config: `budget >= 1` must hold, but got budget=0"),
        ("run.workers=0", "config: `run.workers >= 1` must hold, but got run.workers=0"),
        ("run.worker=2", "unknown key run.'worker'; did you mean 'workers'?"),
        ("bugdet=3", "unknown key 'bugdet'; did you mean 'budget'?"),
    ],
)
def test_config_errors_name_key_rule_and_value(tmp_path, override, needle):
    with pytest.raises(ValidationError) as e:
        load_config(_write(tmp_path), [override])
    assert needle in str(e.value)


def test_parse_override_types():
    assert parse_override("a.b=3") == (["a", "b"], 3)
    assert parse_override("a=0.5") == (["a"], 0.5)
    assert parse_override("a=true") == (["a"], True)
    assert parse_override("a=rank_sum") == (["a"], "rank_sum")
    assert parse_override("a=[1, 2]") == (["a"], [1, 2])
    with pytest.raises(ValidationError, match="key=value"):
        parse_override("nokey")


def test_unknown_problem_suggests(tmp_path):
    path = _write(tmp_path)
    cfg = load_config(path, ['problem.name="Spher"'])
    with pytest.raises(ValidationError, match="did you mean 'Sphere'"):
        run_experiment(cfg)


def test_compare_strategies_over_seeds(tmp_path):
    runs = []
    for strat in ("cmaes", "random"):
        for seed in (1, 2):
            cfg = load_config(_write(tmp_path, strat, f"{strat}"), [f"seed={seed}"])
            runs.append(run_experiment(cfg)[0])
    result = write_comparison(runs, tmp_path / "cmp")
    rows = {r["strategy"]: r for r in result["table"]}
    assert rows["cmaes"]["runs"] == 2 and rows["random"]["seeds"] == [1, 2]
    # on a 4-D sphere with 120 evaluations CMA-ES beats random search (both seeds)
    assert rows["cmaes"]["best_max"] < rows["random"]["best_min"]
    assert (tmp_path / "cmp" / "compare.png").is_file()
    assert np.isfinite(rows["cmaes"]["best_median"])


def test_versions_record_the_source_commit():
    # reference: git itself, asked about the checkout the package runs from
    import shutil
    import subprocess
    from pathlib import Path

    from suspenv.runs import versions
    from suspenv.runs.versions import package_versions

    # asked once per process; forget what an earlier test asked (a commit may have been
    # made since, while this test process ran)
    versions.source_commit.cache_clear()
    versions._tracked_versions.cache_clear()
    root = Path(__file__).resolve().parents[1]
    if shutil.which("git") is None or not (root / ".git").exists():
        pytest.skip("not a git checkout")
    head = subprocess.run(
        ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    commit = package_versions()["suspenv_commit"]
    assert commit.removesuffix("+modified") == head


def test_a_config_does_not_run_code_unless_the_user_says_so(tmp_path):
    from suspenv.core.errors import ValidationError
    from suspenv.runs.config import load_config

    cfg = tmp_path / "evil.toml"
    cfg.write_text(
        'pipeline = "tey2014"\nbudget = 10\n[problem]\nname = "os:system"\n'
        'options = {}\n[strategy]\nname = "cmaes"\n'
    )
    with pytest.raises(ValidationError, match=r"names code to import.*--allow-code"):
        load_config(cfg)
    with pytest.raises(ValidationError, match="cannot be set by a config"):
        load_config(cfg, ["run.allow_code=true"])
    assert load_config(cfg, allow_code=True)["problem"]["name"] == "os:system"
    # nothing was imported or run, and no run directory was made
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("name", ["../escape", "/abs/path", ".hidden", "a/b", "", "x" * 200])
def test_run_names_stay_inside_the_output_folder(tmp_path, name):
    from suspenv.core.errors import ValidationError
    from suspenv.runs.config import load_config

    cfg = tmp_path / "c.toml"
    cfg.write_text('budget = 4\n[problem]\nname = "Sphere"\n[strategy]\nname = "random"\n')
    with pytest.raises(ValidationError, match="plain file name"):
        load_config(cfg, [f"name={name!r}".replace("'", '"')])
