"""Property-based tests of the command line's `export optuna`, `compare` and `suite run`,
through :func:`suspenv.cli.main.main` only.

Property: whatever the storage URL, options and inputs, the command returns an exit code
(0, or 2 after printing a named suspenv error) or argparse refuses the usage (exit 2);
never another exception (a traceback for the user), and each example ends within its
deadline (no hang). Storage URLs name no host but this machine's loopback, so a fuzzed
URL never reaches the network.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from datetime import timedelta
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import suspenv.suite.runner as suite_runner  # noqa: E402
from suspenv.cli.main import main  # noqa: E402
from suspenv.core.tomlfile import dump_toml  # noqa: E402
from suspenv.runs.config import load_config  # noqa: E402
from suspenv.runs.runner import run_experiment  # noqa: E402

#: CI replays a fixed set of examples; a per-example deadline catches a hang
SETTINGS = settings(
    max_examples=25,
    deadline=timedelta(seconds=5),
    derandomize=bool(os.environ.get("CI")),
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

CONFIG = {
    "name": "fuzz",
    "budget": 10,
    "problem": {"name": "Sphere", "options": {"dim": 2}},
    "strategy": {"name": "random", "options": {"batch_size": 5}},
    "run": {"plots": False, "progress": False},
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> list[Path]:
    """Two tiny finished runs (seeds 1, 2) of one strategy on Sphere."""
    root = tmp_path_factory.mktemp("runs")
    out = []
    for seed in (1, 2):
        path = root / f"seed{seed}.toml"
        config = {**CONFIG, "seed": seed, "run": {**CONFIG["run"], "output": str(root)}}
        path.write_text(dump_toml(config))
        run_dir, _ = run_experiment(load_config(path))
        out.append(run_dir)
    return out


def _exit_code(argv: list[str]) -> int:
    """``main(argv)``'s exit code; argparse's usage error counts as exit 2."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code or 0) if not isinstance(exc.code, str) else 2


# ------------------------------------------------------------------ export optuna
TEXT = st.text(
    st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=20
)
SCHEMES = st.sampled_from(
    [
        "sqlite",
        "sqlite+pysqlite",
        "postgresql",
        "mysql",
        "mysql+pymysql",
        "oracle",
        "mssql",
        "redis",
        "http",
        "file",
        "",
        "SQLITE",
        "sqlite:",
        "nosuchdb",
        "sqlite+nosuchdriver",
    ]
)
HOSTS = st.sampled_from(["", "127.0.0.1", "localhost", "127.0.0.1:1", "[::1]", "u:p@127.0.0.1"])


@st.composite
def storages(draw, folder: str) -> str:
    """A storage URL (scheme, loopback host, path, query) or a plain path, in ``folder``."""
    kind = draw(st.sampled_from(["url", "path", "text"]))
    if kind == "text":
        return draw(TEXT)
    name = draw(st.sampled_from(["db.sqlite", "", ".", "..", "a/b.db", "archive.sqlite"]))
    name = draw(st.one_of(st.just(name), TEXT))
    path = f"{folder}/{name}"
    if kind == "path":
        return path
    query = draw(st.sampled_from(["", "?timeout=1", "?mode=ro", "?x=%zz", "#frag"]))
    slashes = draw(st.sampled_from(["///", "//", ":/", "////"]))
    host = draw(HOSTS)
    return f"{draw(SCHEMES)}:{slashes[:2]}{host}{slashes[2:]}{path}{query}"


@settings(SETTINGS, max_examples=12)
@given(data=st.data(), replace=st.booleans(), study=st.one_of(st.none(), TEXT))
def test_export_optuna_any_storage_is_written_or_named(runs, data, replace, study, capsys):
    # a relative path is a file in the working folder: keep it in the temporary one
    with tempfile.TemporaryDirectory() as folder, contextlib.chdir(folder):
        storage = data.draw(storages(folder))
        argv = ["export", "optuna", str(runs[0]), "--storage", storage]
        argv += ["--replace"] * replace + ([] if study is None else ["--study", study])
        assert _exit_code(argv) in (0, 2)
        err = capsys.readouterr().err
        if err and "error" in err:  # a refusal names the command and the rule
            assert "suspenv export: error:" in err or "usage:" in err


# ------------------------------------------------------------------ compare
NUMBERS = st.sampled_from(["0", "1", "-1", "21", "1e308", "nan", "inf", "-inf", "0.5", "x", ""])
COMPARE_OPTIONS = st.lists(
    st.one_of(
        st.tuples(
            st.sampled_from(["--f-opt", "--n-targets", "--alpha", "--measure"]),
            st.one_of(NUMBERS, st.sampled_from(["auto", "quality", "hypervolume", "hv"])),
        ).map(list),
        st.sampled_from([["--suite"], ["--allow-unequal-budgets"], ["--ioh"], ["--zz"]]),
    ),
    max_size=4,
)
INPUTS = st.lists(
    st.sampled_from(["run1", "run2", "missing", "empty", "file", "garbage_archive", "parent"]),
    min_size=1,
    max_size=3,
)


def _inputs(names: list[str], runs: list[Path], folder: Path) -> list[str]:
    """Run directories, a missing one, an empty folder, a plain file, a folder with a
    damaged archive, and the folder holding both runs."""
    (folder / "empty").mkdir(exist_ok=True)
    (folder / "file").write_text("not a run\n")
    bad = folder / "garbage_archive"
    bad.mkdir(exist_ok=True)
    (bad / "archive.sqlite").write_bytes(b"SQLite format 3\x00" + b"\xff" * 64)
    where = {"run1": runs[0], "run2": runs[1], "parent": runs[0].parent}
    return [str(where.get(n, folder / n)) for n in names]


@SETTINGS
@given(names=INPUTS, options=COMPARE_OPTIONS)
def test_compare_any_inputs_and_options_compare_or_name_the_error(runs, names, options):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        argv = ["compare", *_inputs(names, runs, folder), "--out", str(folder / "out")]
        argv += [word for option in options for word in option] + ["--no-plots"]
        assert _exit_code(argv) in (0, 2)


# ------------------------------------------------------------------ suite run
class StartedError(Exception):
    """Raised in place of the first run: every option was accepted before any work."""


@SETTINGS
@given(
    strategies=st.lists(
        st.sampled_from(["random", "cmaes", "lhs", "nosuch", "", "strategies/none.py:X"]),
        min_size=0,
        max_size=3,
    ),
    seeds=st.one_of(st.none(), st.lists(st.sampled_from(["1", "2", "-1", "0", "x"]), max_size=3)),
    # always named: checking every instance (the default) takes ~8 s before any run
    functions=st.lists(
        st.sampled_from(["sphere-10d", "zdt1-6d/i1", "sphere-10d/i9", "x/i", "", "nosuch"]),
        min_size=1,
        max_size=2,
    ),
    alpha=st.sampled_from(["0.05", "0", "1", "nan", "-1", "x"]),
    scale=st.sampled_from(["1", "0.01", "0", "-1", "nan", "inf", "1e-300"]),
    workers=st.sampled_from(["1", "0", "-2", "3"]),
)
def test_suite_run_any_options_start_or_name_the_error(
    monkeypatch, strategies, seeds, functions, alpha, scale, workers
):
    def started(config):
        raise StartedError

    monkeypatch.setattr(suite_runner, "run_experiment", started)
    with tempfile.TemporaryDirectory() as tmp:
        argv = ["suite", "run", "--strategies", *strategies, "--out", f"{tmp}/suite", "--quiet"]
        if seeds is not None:
            argv += ["--seeds", *seeds]
        argv += ["--functions", *functions]
        argv += ["--alpha", alpha, "--budget-scale", scale, "--workers", workers]
        with contextlib.suppress(StartedError):
            assert _exit_code(argv) in (0, 2)
        shutil.rmtree(tmp, ignore_errors=True)


@pytest.mark.parametrize("name", ["x{.db", "x}.db", "{0}.db", "{a.b}.db"])
def test_export_optuna_names_braces_in_the_storage(runs, tmp_path, name, capsys):
    """Found by the fuzz test: optuna fills the URL as a ``str.format`` template, so a
    lone brace in a path was a ValueError traceback; now a named refusal."""
    storage = str(tmp_path / name)
    assert _exit_code(["export", "optuna", str(runs[0]), "--storage", storage]) == 2
    assert "has braces that are not a template field" in capsys.readouterr().err
    assert not (tmp_path / name).exists()
