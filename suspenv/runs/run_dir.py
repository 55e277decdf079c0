"""Run directories: ``<output>/<name>-seed<seed>/`` with the resolved config and versions;
the ``summary.json`` of a finished one (:func:`load_summary`)."""

from __future__ import annotations

import contextlib
import json
import os
import sqlite3
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from suspenv.core.atomic import write_file
from suspenv.core.errors import ValidationError
from suspenv.core.jsonable import json_text
from suspenv.core.tomlfile import dump_toml
from suspenv.runs.versions import package_versions


def write_json(path: Path | str, value: Any) -> Path:
    """``value`` as indented, standard JSON (:func:`suspenv.core.jsonable.json_text`:
    numpy values as Python values, NaN and infinities as ``null``), atomically
    (:func:`write_file`)."""
    return write_file(path, json_text(value))


def run_directory(config: dict[str, Any]) -> Path:
    """The run directory of a resolved config (not created); a symbolic link there is
    refused, since a run writes (and ``--overwrite`` deletes) only inside its output
    folder."""
    path = Path(config["run"]["output"]) / f"{config['name']}-seed{config['seed']}"
    if path.is_symlink():
        raise ValidationError(
            f"run directory {str(path)!r} is a symbolic link (to {os.readlink(path)!r}); "
            "a run writes only inside its output folder: remove the link, or give "
            "another `name`/`seed`"
        )
    return path


def prepare_run_dir(config: dict[str, Any]) -> Path:
    """Create the run directory; write ``config.resolved.toml`` and ``versions.json``."""
    path = run_directory(config)
    path.mkdir(parents=True, exist_ok=True)
    write_file(path / "config.resolved.toml", dump_toml(config))
    write_json(path / "versions.json", package_versions())
    return path


#: the lock file inside a run directory, held while a run writes into it
LOCK_FILE = ".lock"


@contextlib.contextmanager
def locked(path: Path, lock_name: str = LOCK_FILE, what: str = "run directory") -> Iterator[None]:
    """Hold the lock of folder ``path`` for the block (the folder is created).

    Two runs of one config would otherwise evaluate into one archive; the second is
    refused at once with the first one's process id. The lock is an ``flock`` on
    ``<path>/<lock_name>``: the operating system releases it when the holder dies, so a
    killed run never leaves a stale lock behind. ``what`` names the folder in the error."""
    path.mkdir(parents=True, exist_ok=True)
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield
        return
    fh = (path / lock_name).open("a+")
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "unknown"
            raise ValidationError(
                f"{what} {str(path)!r} is in use by another run ({holder}); wait for "
                "it to finish, or give this run another `name` or `seed`"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}\n")
        fh.flush()
        yield
    finally:
        fh.close()  # closing the file releases the lock


def holds_results(path: Path) -> bool:
    """True when the run directory holds anything a run produced: an archive with at
    least one evaluation (at any depth), a ``rows.jsonl`` with a row, or a summary."""
    if (path / "summary.json").exists():
        return True
    for rows in path.rglob("rows.jsonl"):
        if rows.stat().st_size > 0:
            return True
    for db in path.rglob("archive.sqlite"):
        try:
            n = read_only_row(db, "SELECT COUNT(*) FROM evaluations")[0]
        except sqlite3.Error:
            return True  # unreadable: keep it, let the user decide
        if n:
            return True
    return False


def read_only_row(db: Path, sql: str) -> Any:
    """The first row of ``sql`` (None: no row) on the SQLite file ``db`` opened read-only:
    nothing is created, locked for writing or changed. Raises ``sqlite3.Error``."""
    with contextlib.closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True)) as con:
        return con.execute(sql).fetchone()


def load_summary(run_dir: str | Path) -> dict[str, Any]:
    """The ``summary.json`` of a finished run directory."""
    path = Path(run_dir) / "summary.json"
    if not path.is_file():
        raise ValidationError(
            f"{str(run_dir)!r} is not a finished run directory (no summary.json); "
            "a run that died can be resumed with `suspenv run CONFIG`"
        )
    try:
        summary = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValidationError(
            f"{str(path)!r} is damaged (not valid JSON: {exc}); restore it from a copy, "
            "or start the run anew with `suspenv run CONFIG --overwrite`"
        ) from None
    if not isinstance(summary, dict):
        raise ValidationError(
            f"{str(path)!r} must hold a JSON object, but holds a {type(summary).__name__}"
        )
    return summary
