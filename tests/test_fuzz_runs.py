"""Property-based tests of the run readers: experiment configs and run archives.

Property: whatever the input, a reader either returns a well-formed value or raises
ValidationError naming what is wrong; never another exception (a traceback for the user),
and a config check never writes a file.
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
import tempfile
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from suspenv import make_problem  # noqa: E402
from suspenv.core.errors import ValidationError  # noqa: E402
from suspenv.core.tomlfile import dump_toml  # noqa: E402
from suspenv.registry import make_strategy  # noqa: E402
from suspenv.runs.archive import RunArchive  # noqa: E402
from suspenv.runs.config import load_config  # noqa: E402
from suspenv.runs.loop import optimize  # noqa: E402
from suspenv.runs.runner import check_config  # noqa: E402

#: CI replays a fixed set of examples (a run either passes or fails for a reason in the
#: code, not in the draw); elsewhere every run explores new ones
SETTINGS = settings(
    max_examples=60,
    deadline=None,
    derandomize=bool(os.environ.get("CI")),
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

#: words a config is made of: the real keys, near misses and nonsense
KEYS = st.sampled_from(
    [
        "name",
        "seed",
        "budget",
        "pipeline",
        "problem",
        "strategy",
        "run",
        "options",
        "dim",
        "delay_s",
        "popsize",
        "sigma0",
        "restarts",
        "batch_size",
        "workers",
        "output",
        "plots",
        "progress",
        "chunk_size",
        "timeout_s",
        "retries",
        "retry_backoff_s",
        "dask_scheduler",
        "optons",
        "sigma",
        "x0",
        "weights",
        "zz",
    ]
)
SCALARS = st.one_of(
    st.integers(min_value=-3, max_value=50),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.booleans(),
    st.sampled_from(["Sphere", "ZDT1", "cmaes", "random", "lhs", "nsga2", "x", "", "../up"]),
)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(KEYS, inner, max_size=4)),
    max_leaves=12,
)


def _toml_safe(value: object) -> bool:
    """TOML has no heterogeneous-array restrictions left, but our writer has no None."""
    if isinstance(value, float):
        return True
    if isinstance(value, list):
        return all(_toml_safe(v) for v in value)
    if isinstance(value, dict):
        return all(_toml_safe(v) for v in value.values())
    return value is not None


BASE = {
    "name": "fuzz",
    "seed": 1,
    "budget": 10,
    "problem": {"name": "Sphere", "options": {"dim": 2}},
    "strategy": {"name": "random", "options": {"batch_size": 5}},
    "run": {"plots": False, "progress": False},
}


@SETTINGS
@given(
    edits=st.lists(
        st.tuples(st.lists(KEYS, min_size=1, max_size=3), VALUES), min_size=1, max_size=4
    )
)
def test_any_config_loads_and_checks_or_names_its_error(tmp_path, edits):
    config = json.loads(json.dumps(BASE))
    for path, value in edits:
        node = config
        for part in path[:-1]:
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                break
            node = nxt
        else:
            node[path[-1]] = value
    config.setdefault("run", {})
    if isinstance(config["run"], dict):
        config["run"]["output"] = str(tmp_path / "runs")
    file = tmp_path / "fuzz.toml"
    file.write_text(dump_toml(config))
    try:
        resolved = check_config(load_config(file))
    except ValidationError as exc:
        assert str(exc)  # a named error
    else:
        assert isinstance(resolved["budget"], int) and resolved["budget"] >= 1
        assert math.isfinite(resolved["run"]["timeout_s"])
    assert not (tmp_path / "runs").exists(), "a config check wrote files"


@pytest.fixture(scope="module")
def archive_bytes(tmp_path_factory) -> bytes:
    path = tmp_path_factory.mktemp("archive")
    p = make_problem("Sphere", dim=3)
    optimize(p, make_strategy("random", p, seed=1, batch_size=4), 12, run_dir=path)
    with sqlite3.connect(path / "archive.sqlite") as con:  # one file, no WAL beside it
        con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        con.execute("PRAGMA journal_mode=DELETE")
    return (path / "archive.sqlite").read_bytes()


def _read(path: Path) -> None:
    with RunArchive(path) as archive:
        arrays = archive.arrays()
        n = len(arrays["ok"])
        assert arrays["x"].shape[0] == arrays["objectives"].shape[0] == n
        archive.batch(0)
        archive.to_csv(path.parent / "out.csv")


@SETTINGS
@given(
    flips=st.lists(
        st.tuples(st.integers(min_value=0, max_value=10**6), st.integers(0, 255)), max_size=8
    ),
    cut=st.one_of(st.none(), st.integers(min_value=0, max_value=10**6)),
)
def test_a_damaged_archive_reads_or_names_its_damage(tmp_path, archive_bytes, flips, cut):
    # (the failing example hypothesis prints holds the whole file: read its last lines)
    data = bytearray(archive_bytes)
    for at, value in flips:
        data[at % len(data)] = value
    if cut is not None:
        data = data[: cut % (len(data) + 1)]
    folder = Path(tempfile.mkdtemp(dir=tmp_path))
    (folder / "archive.sqlite").write_bytes(bytes(data))
    try:
        _read(folder / "archive.sqlite")
    except ValidationError as exc:
        assert "archive" in str(exc)


def test_a_header_naming_an_unknown_schema_format_is_named_damage(tmp_path, archive_bytes):
    # found by the test above: SQLite reports this damage as an OperationalError
    # ("unsupported file format"), which was taken for a full disk or a read-only folder
    data = bytearray(archive_bytes)
    data[47] = 5  # the header's schema format number (bytes 44-47): 1 to 4 exist
    (tmp_path / "archive.sqlite").write_bytes(bytes(data))
    with pytest.raises(ValidationError, match="is not a suspenv run archive"):
        _read(tmp_path / "archive.sqlite")


@SETTINGS
@given(
    blob=st.binary(max_size=40),
    ok=st.one_of(st.integers(-2, 2), st.text(max_size=3)),
    batch=st.one_of(st.integers(-5, 5), st.text(max_size=3), st.floats(allow_nan=False)),
)
def test_rows_written_by_another_program_read_or_name_the_damage(tmp_path, blob, ok, batch):
    folder = Path(tempfile.mkdtemp(dir=tmp_path))
    p = make_problem("Sphere", dim=3)
    optimize(p, make_strategy("random", p, seed=1, batch_size=2), 2, run_dir=folder)
    with sqlite3.connect(folder / "archive.sqlite") as con:
        con.execute(
            "INSERT INTO evaluations(batch, row, n, unit, x, objectives, constraints, ok, "
            "message, wall_time, created) VALUES (?, 9, 1, ?, ?, ?, ?, ?, '[\"m\"]', 0.0, 0.0)",
            (batch, blob, blob, blob, np.zeros(0).tobytes(), ok),
        )
    try:
        _read(folder / "archive.sqlite")
    except ValidationError as exc:
        assert "archive" in str(exc)


@pytest.mark.parametrize("table", ["problem", "strategy", "run"])
def test_a_table_that_is_a_value_is_named(table):
    # found by the property test above: `run = 1` reached `"allow_code" in 1`
    from suspenv.runs.config import validate

    with pytest.raises(ValidationError, match=f"`{table}` must be a table"):
        validate({"name": "x", "budget": 1, table: 1})
