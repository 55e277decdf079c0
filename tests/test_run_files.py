"""The files of a run directory: written atomically, checked when read back.

* Atomic writes: every file goes to a temporary name, is flushed and renamed; a write
  that fails (a full disk, simulated by making ``os.write``/``os.replace`` raise ENOSPC,
  or a read-only folder) is a named error and leaves the previous file whole.
* Damaged files (a truncated ``config.resolved.toml``, ``versions.json`` or
  ``summary.json``) are named with what to do, and ``--overwrite`` starts such a folder
  anew.
* Links: a run directory that is a link, or holds one, is refused; ``--overwrite``
  never follows it (the link's target is left as it was).
* Archive integrity: one flipped byte of a stored row (the ``x`` column) is caught on
  resume, CSV regeneration and export; an archive emptied beside a summary that counts
  evaluations is refused; an archive written before rows had checksums is migrated.
"""

from __future__ import annotations

import errno
import os
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from strict_json import strict_loads

from suspenv import make_problem
from suspenv.core.atomic import write_file
from suspenv.core.errors import InfrastructureError, ValidationError
from suspenv.registry import make_strategy
from suspenv.runs import run_dir as run_dir_module
from suspenv.runs.archive import RunArchive
from suspenv.runs.config import load_config
from suspenv.runs.loop import optimize
from suspenv.runs.runner import run_experiment

CONFIG = """
name = "files"
seed = 2
budget = 24
[problem]
name = "Sphere"
options = {{ dim = 3 }}
[strategy]
name = "random"
options = {{ batch_size = 6 }}
[run]
output = "{output}"
plots = false
progress = false
"""


def config_file(tmp_path: Path) -> Path:
    path = tmp_path / "files.toml"
    path.write_text(CONFIG.format(output=tmp_path / "runs"))
    return path


def finished_run(tmp_path: Path) -> Path:
    run_dir, summary = run_experiment(load_config(config_file(tmp_path)))
    assert summary["n_evaluations"] == 24
    return run_dir


# ------------------------------------------------------------------ atomic writes
def test_run_files_are_standard_json(tmp_path):
    # RFC 8259 has no NaN or Infinity token: a value a run cannot define is written null
    value = {"best": np.float64(np.nan), "curve": np.array([np.inf, 1.5]), "n": np.int64(3)}
    path = run_dir_module.write_json(tmp_path / "value.json", value)
    assert strict_loads(path.read_text()) == {"best": None, "curve": [None, 1.5], "n": 3}
    run_dir = finished_run(tmp_path)
    for name in ("summary.json", "versions.json"):
        assert strict_loads((run_dir / name).read_text())


def test_a_failed_write_is_named_and_leaves_the_old_file_whole(tmp_path, monkeypatch):
    target = tmp_path / "summary.json"
    write_file(target, "old\n")

    def full(fd, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "write", full)
    with pytest.raises(InfrastructureError, match=r"no space left on the device \(ENOSPC\)"):
        write_file(target, "new content\n" * 1000)
    monkeypatch.undo()
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]  # no temporary left


def test_a_failed_rename_is_named_and_leaves_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "config.resolved.toml"

    def read_only(src, dst):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(os, "replace", read_only)
    with pytest.raises(InfrastructureError, match="read-only.*run the same command again"):
        write_file(target, "x = 1\n")
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_at_the_end_of_a_run_is_named_and_resume_completes(tmp_path, monkeypatch):
    path = config_file(tmp_path)
    real = run_dir_module.os.replace

    def full(src, dst):
        if str(dst).endswith("summary.json"):
            raise OSError(errno.ENOSPC, "No space left on device")
        real(src, dst)

    monkeypatch.setattr(run_dir_module.os, "replace", full)
    with pytest.raises(InfrastructureError, match="summary.json.*no space left"):
        run_experiment(load_config(path))
    monkeypatch.undo()
    run_dir = tmp_path / "runs" / "files-seed2"
    assert not (run_dir / "summary.json").exists()
    assert not [p for p in run_dir.iterdir() if ".tmp-" in p.name]
    _, summary = run_experiment(load_config(path))
    assert summary["n_resumed"] == 24 and summary["n_evaluations"] == 24


# ------------------------------------------------------------------ damaged files
@pytest.mark.parametrize("name", ["config.resolved.toml", "versions.json", "summary.json"])
def test_a_truncated_run_file_is_named_and_overwrite_starts_anew(tmp_path, name):
    run_dir = finished_run(tmp_path)
    text = (run_dir / name).read_text()
    (run_dir / name).write_text(text[: len(text) // 2])
    with pytest.raises(ValidationError, match=f"{name}' is damaged.*--overwrite"):
        run_experiment(load_config(config_file(tmp_path)))
    _, summary = run_experiment(load_config(config_file(tmp_path)), overwrite=True)
    assert summary["n_evaluations"] == 24 and summary["n_resumed"] == 0


def test_a_damaged_config_beside_no_results_is_replaced(tmp_path):
    run_dir = tmp_path / "runs" / "files-seed2"
    run_dir.mkdir(parents=True)
    (run_dir / "config.resolved.toml").write_text('name = "fi')
    _, summary = run_experiment(load_config(config_file(tmp_path)))
    assert summary["n_evaluations"] == 24


# -------------------------------------------------------------------------- links
def test_a_linked_run_directory_is_refused_with_and_without_overwrite(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.txt").write_text("mine")
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "files-seed2").symlink_to(outside, target_is_directory=True)
    for overwrite in (False, True):
        with pytest.raises(ValidationError, match="is a symbolic link"):
            run_experiment(load_config(config_file(tmp_path)), overwrite=overwrite)
    assert (outside / "keep.txt").read_text() == "mine"
    assert [p.name for p in outside.iterdir()] == ["keep.txt"]


def test_a_link_inside_a_run_directory_is_refused_and_overwrite_removes_only_it(tmp_path):
    run_dir = finished_run(tmp_path)
    outside = tmp_path / "outside.sqlite"
    outside.write_bytes(b"not yours")
    (run_dir / "archive.sqlite").unlink()
    (run_dir / "archive.sqlite").symlink_to(outside)
    with pytest.raises(ValidationError, match="holds a symbolic link 'archive.sqlite'"):
        run_experiment(load_config(config_file(tmp_path)))
    _, summary = run_experiment(load_config(config_file(tmp_path)), overwrite=True)
    assert summary["n_evaluations"] == 24
    assert outside.read_bytes() == b"not yours"
    assert not (run_dir / "archive.sqlite").is_symlink()


# -------------------------------------------------------------- archive integrity
def flip_x_byte(db: Path, row_id: int = 2) -> None:
    """Change one byte of the physical ``x`` values of one stored chunk."""
    with sqlite3.connect(db) as con:
        (x,) = con.execute("SELECT x FROM evaluations WHERE id = ?", (row_id,)).fetchone()
        bad = bytearray(x)
        bad[5] ^= 0x01
        con.execute("UPDATE evaluations SET x = ? WHERE id = ?", (bytes(bad), row_id))


def test_a_flipped_byte_in_x_is_caught_on_resume_csv_and_export(tmp_path):
    run_dir = finished_run(tmp_path)
    flip_x_byte(run_dir / "archive.sqlite")
    (run_dir / "summary.json").unlink()  # a resume that reaches the replay
    with pytest.raises(ValidationError, match="does not match its checksum"):
        run_experiment(load_config(config_file(tmp_path)))
    with RunArchive(run_dir) as archive, pytest.raises(ValidationError, match="checksum"):
        archive.to_csv(tmp_path / "out.csv")
    assert not (tmp_path / "out.csv").exists()
    pytest.importorskip("optuna")
    from suspenv.runs.export import export_optuna

    with pytest.raises(ValidationError, match="checksum"):
        export_optuna(run_dir, str(tmp_path / "study.db"))


def test_the_row_checksum_definition_is_fixed():
    # golden: integer arithmetic only (no float operation), so the same on every machine;
    # a change would make every archive written before it unreadable
    from suspenv.runs.archive import checksums

    cols = [np.array([[0.5]]), np.array([[2.0]]), np.array([[1.0, -1.0]]), np.zeros((1, 0))]
    assert checksums([1], [2], [1], ["m"], cols)[0].hex() == "28aa04235e8d2f26"


@pytest.mark.parametrize(
    ("column", "byte"),
    [("unit", 0), ("x", 15), ("objectives", 27), ("ok", 2), ("message", None), ("row", None)],
)
def test_a_change_in_any_checked_column_is_caught(tmp_path, column, byte):
    # a change of one design's value in a chunk of 4 (batch 1): bytes of its blobs, its
    # status, its message (the chunk's JSON list still well-formed), the chunk's rows
    p = make_problem("Sphere", dim=3)
    optimize(p, make_strategy("random", p, seed=1, batch_size=4), 8, run_dir=tmp_path)
    with sqlite3.connect(tmp_path / "archive.sqlite") as con:
        (value,) = con.execute(f"SELECT {column} FROM evaluations WHERE id = 2").fetchone()
        if byte is not None:
            changed: object = bytes(b ^ (1 if i == byte else 0) for i, b in enumerate(value))
        elif column == "message":
            changed = value.replace('""', '"x"', 1)
        else:
            changed = value + 10
        assert changed != value
        con.execute(f"UPDATE evaluations SET {column} = ? WHERE id = 2", (changed,))
    with RunArchive(tmp_path) as archive, pytest.raises(ValidationError, match="checksum"):
        archive.arrays()


@pytest.mark.parametrize(
    ("column", "value"),
    [("n", 3), ("ok", b"\x01"), ("message", '["", ""]'), ("unit", b"\x00" * 20), ("n", "four")],
)
def test_a_chunk_whose_sizes_do_not_fit_is_named_damage(tmp_path, column, value):
    p = make_problem("Sphere", dim=3)
    optimize(p, make_strategy("random", p, seed=1, batch_size=4), 8, run_dir=tmp_path)
    with sqlite3.connect(tmp_path / "archive.sqlite") as con:
        con.execute(f"UPDATE evaluations SET {column} = ? WHERE id = 2", (value,))
    with RunArchive(tmp_path) as archive, pytest.raises(ValidationError, match="not in the layout"):
        archive.arrays()


def test_overlapping_chunks_are_named_damage(tmp_path):
    p = make_problem("Sphere", dim=3)
    optimize(p, make_strategy("random", p, seed=1, batch_size=4), 8, run_dir=tmp_path)
    with sqlite3.connect(tmp_path / "archive.sqlite") as con:  # batch 1's rows 2, 3 again
        con.execute(
            "INSERT INTO evaluations(batch, row, n, unit, x, objectives, constraints, ok, "
            "message, wall_time, created, checksum) SELECT batch, 2, 2, substr(unit, 49), "
            'substr(x, 49), substr(objectives, 17), constraints, substr(ok, 3), \'["", ""]\', '
            "wall_time, created, substr(checksum, 17) FROM evaluations WHERE id = 2"
        )
    with RunArchive(tmp_path) as archive, pytest.raises(ValidationError, match="row 2 twice"):
        archive.arrays()


def test_an_emptied_archive_beside_its_summary_is_refused(tmp_path):
    run_dir = finished_run(tmp_path)
    (run_dir / "archive.sqlite").unlink()
    with pytest.raises(ValidationError, match=r"holds 0 evaluation\(s\), but .*summary.json"):
        run_experiment(load_config(config_file(tmp_path)))


def test_deleted_rows_are_refused_by_the_archive_meta(tmp_path):
    p = make_problem("Sphere", dim=2)
    optimize(p, make_strategy("random", p, seed=1, batch_size=4), 12, run_dir=tmp_path)
    with sqlite3.connect(tmp_path / "archive.sqlite") as con:
        con.execute("DELETE FROM evaluations WHERE batch = 2")
    with pytest.raises(ValidationError, match=r"holds 8 evaluation\(s\), but its meta says 12"):
        optimize(p, make_strategy("random", p, seed=1, batch_size=4), 12, run_dir=tmp_path)


def _one_row_per_design(db: Path, arrays: dict, checksums: bool) -> None:
    """An archive as written before chunks (one row per design), with or without the
    checksum column (before checksums), holding ``arrays``; the meta of ``db`` kept."""
    from suspenv.runs.archive import checksums as row_checksums

    with sqlite3.connect(db) as con:
        con.execute("DROP TABLE evaluations")
        con.execute(
            "CREATE TABLE evaluations (id INTEGER PRIMARY KEY, batch INTEGER NOT NULL, "
            "row INTEGER NOT NULL, unit BLOB NOT NULL, x BLOB NOT NULL, objectives BLOB "
            "NOT NULL, constraints BLOB NOT NULL, ok INTEGER NOT NULL, message TEXT NOT "
            "NULL, wall_time REAL NOT NULL, created REAL NOT NULL, "
            + ("checksum BLOB, " if checksums else "")
            + "UNIQUE (batch, row))"
        )
        a = arrays
        cols = [a["unit"], a["x"], a["objectives"], a["constraints"]]
        ok = a["ok"].astype(int).tolist()
        sums = row_checksums(a["batch"].tolist(), a["row"].tolist(), ok, list(a["message"]), cols)
        for i in range(len(ok)):
            values = [int(a["batch"][i]), int(a["row"][i]), *(c[i].tobytes() for c in cols)]
            values += [ok[i], a["message"][i], 0.1, 0.0] + ([sums[i]] if checksums else [])
            con.execute(
                f"INSERT INTO evaluations VALUES (NULL, {', '.join('?' * len(values))})", values
            )


@pytest.mark.parametrize("checksums", [True, False])
def test_an_archive_of_one_row_per_design_is_converted_and_then_checked(tmp_path, checksums):
    # reference: the arrays the run archived, written back in the layout of one row per
    # design (with and without the checksums of the last layout but one)
    p = make_problem("Sphere", dim=2)
    optimize(p, make_strategy("random", p, seed=1, batch_size=4), 8, run_dir=tmp_path)
    db = tmp_path / "archive.sqlite"
    with RunArchive(db) as archive:
        before = archive.arrays()
    before["message"][5] = "failed: ü"  # a message survives the conversion
    before["ok"][5] = False
    _one_row_per_design(db, before, checksums)
    with RunArchive(db) as archive:
        after = archive.arrays()
        assert len(archive) == 8
        assert ("checksums_added" in archive.meta()) is not checksums
        assert "chunks_added" in archive.meta()
    for key in ("unit", "x", "objectives", "constraints", "ok", "message", "batch", "row"):
        np.testing.assert_array_equal(before[key], after[key])
    # the converted archive resumes: its 8 designs replayed, the run goes on after them
    r = optimize(p, make_strategy("random", p, seed=1, batch_size=4), 12, run_dir=tmp_path)
    assert r.n_resumed == 8 and r.n_evaluations == 12
    flip_x_byte(db, 6)  # one design per chunk: id 6 is batch 1, row 1
    with RunArchive(db) as archive, pytest.raises(ValidationError, match="batch 1, row 1 does"):
        archive.arrays()


# ------------------------------------------------------------- checked at load
@pytest.mark.parametrize(
    ("key", "value", "needle"),
    [
        ("run.dask_scheduler", '"http://127.0.0.1:8786"', "run.dask_scheduler"),
        ("run.dask_scheduler", '"tcp://"', "run.dask_scheduler"),
        ("stduy", "{}", "unknown key 'stduy'"),  # a top-level key of no pipeline
    ],
)
def test_bad_values_are_refused_when_the_config_is_loaded(tmp_path, key, value, needle):
    with pytest.raises(ValidationError, match=needle):
        load_config(config_file(tmp_path), [f"{key}={value}"])


@pytest.mark.parametrize(
    ("pipeline", "table"),
    [("tey2014", "study"), ("identify", "identify"), ("diagnosis_benchmark", "benchmark")],
)
def test_every_pipeline_refuses_unknown_top_level_keys(tmp_path, pipeline, table):
    overrides = [f'pipeline="{pipeline}"', f"{table}={{}}"]
    load_config(config_file(tmp_path), overrides)  # its own table is known
    with pytest.raises(ValidationError, match=f"unknown key '{table}x'; did you mean '{table}'"):
        load_config(config_file(tmp_path), [*overrides, f"{table}x={{}}"])


def test_a_budget_smaller_than_the_first_batch_is_refused(tmp_path):
    p = make_problem("Sphere", dim=2)
    with pytest.raises(ValidationError, match="budget=5 is smaller than .* first batch of 12"):
        optimize(p, make_strategy("random", p, seed=1, batch_size=12), 5, run_dir=tmp_path)
    with RunArchive(tmp_path) as archive:
        assert len(archive) == 0


@pytest.fixture
def small_disk(tmp_path):
    """A 384 KiB tmpfs (needs the right to mount: skipped elsewhere)."""
    import subprocess

    mount = tmp_path / "small"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=384k", "tmpfs", str(mount)],
        capture_output=True,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def test_a_full_disk_under_the_archive_is_named_and_the_archive_stays_whole(
    small_disk, monkeypatch
):
    from suspenv.runs.archive import ArchiveWriter

    monkeypatch.setattr(ArchiveWriter, "COMMIT_AFTER_S", 0.0)  # a commit per batch
    p = make_problem("Sphere", dim=40)
    with pytest.raises(InfrastructureError, match="cannot write .*archive.sqlite.*full"):
        optimize(p, make_strategy("random", p, seed=3, batch_size=40), 40_000, run_dir=small_disk)
    with RunArchive(small_disk) as archive:  # every committed row reads back, checksums hold
        a = archive.arrays()
    n = len(a["ok"])
    assert 0 < n < 40_000 and n % 40 == 0  # whole batches only
    np.testing.assert_array_equal(a["batch"], np.repeat(np.arange(n // 40), 40))
    with RunArchive(small_disk) as archive:
        assert archive.meta().get("n_evaluations", 0) <= n  # never counts what is not there
