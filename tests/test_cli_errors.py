"""Bad input at the command line: a named error on one line and exit code 2, before any
work (no run directory, no output folder), never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from suspenv.cli.main import main

CONFIG = """
name = "x"
budget = 10
[problem]
name = "{problem}"
options = {options}
[strategy]
name = "random"
[run]
output = "{output}"
"""

CASES = [
    # (file content or None, argv after the file, words the error must contain)
    (("MinibusRideHandling", '{ road_class = "Z" }'), [], "road_class"),
    (("MinibusRideHandling", "{ speed_kmh = inf }"), [], "speed_kmh"),
    (("PlanarLinkage", "{ target_camber_gain = nan }"), [], "target_camber_gain"),
    (("Sphere", "{ dim = 2.5 }"), [], "dim=2.5"),
    (("Sphere", "{ dimm = 2 }"), [], "did you mean 'dim'"),
    (("Sphere", "{}"), ["--set", "problem.optons={}"], "did you mean 'options'"),
    (("Sphere", "{}"), ["--set", "strategy.option={}"], "did you mean 'options'"),
    (("Sphere", "{}"), ["--set", "strategy.options.batch_size=0"], "batch_size"),
    (("Sphere", "{}"), ["--set", "run.workers=0"], "run.workers"),
    (("Sphere", "{}"), ["--set", "name=../escape"], "plain file name"),
    (("os:system", "{}"), [], "--allow-code"),
]


@pytest.mark.parametrize(("problem", "extra", "needle"), CASES)
def test_bad_configs_are_refused_before_any_work(tmp_path, capsys, problem, extra, needle):
    output = tmp_path / "runs"
    path = tmp_path / "bad.toml"
    path.write_text(CONFIG.format(problem=problem[0], options=problem[1], output=output))
    assert main(["run", str(path), *extra]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
    assert err.startswith("suspenv run: error: ") and err.count("\n") == 1
    assert not output.exists(), "a refused config left files behind"


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "{tmp}/missing.toml"], "does not exist"),
        (["show", "{tmp}"], "not a finished run directory"),
        (["compare", "{tmp}", "{tmp}"], "not a finished run directory"),
        (["diagnose", "{tmp}/garbage.npz"], "not a readable .npz"),
        (["knc", "{tmp}/missing.toml"], "does not exist"),
        (["planar", "{tmp}/garbage.npz"], "not UTF-8 text"),
        (["run", "{tmp}/garbage.npz"], "not UTF-8 text"),
        (["knc", "{tmp}/garbage.npz"], "not UTF-8 text"),
        (["suite", "run", "--strategies", "nope", "--functions", "sphere-10d"], "nope"),
        (["suite", "run", "--strategies", "random", "--functions", "nope"], "nope"),
    ],
)
def test_bad_files_and_names_give_one_line(tmp_path, capsys, argv, needle):
    (tmp_path / "garbage.npz").write_bytes(b"\x00garbage\xff")
    args = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error:" in err[0] and needle in err[0], err
    assert sorted(p.name for p in Path(tmp_path).iterdir()) == ["garbage.npz"]
