"""The append-only evaluation archive: one SQLite file per run directory.

Every evaluation is written as it completes (one transaction per chunk), so a run that
dies loses nothing already evaluated; :func:`suspenv.runs.loop.optimize` replays the
archive to resume without re-evaluating. Arrays are stored as little-endian float64
blobs; :meth:`RunArchive.to_csv` writes a flat table with named columns.

Tables:
    meta(key TEXT PRIMARY KEY, value TEXT)        JSON values: names, config, versions...
    evaluations(id, batch, row, unit, x, objectives, constraints, ok, message,
                wall_time, created)               one row per evaluated design
"""

from __future__ import annotations

import csv
import json
import sqlite3
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.result import EvaluationBatch

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS evaluations (
    id INTEGER PRIMARY KEY,
    batch INTEGER NOT NULL,
    row INTEGER NOT NULL,
    unit BLOB NOT NULL,
    x BLOB NOT NULL,
    objectives BLOB NOT NULL,
    constraints BLOB NOT NULL,
    ok INTEGER NOT NULL,
    message TEXT NOT NULL,
    wall_time REAL NOT NULL,
    created REAL NOT NULL,
    UNIQUE (batch, row)
);
"""


def _blob(a: np.ndarray) -> bytes:
    return np.ascontiguousarray(a, dtype="<f8").tobytes()


def _unblob(b: bytes) -> np.ndarray:
    return np.frombuffer(b, dtype="<f8")


class RunArchive:
    """Append-only SQLite archive of evaluations (``archive.sqlite`` in a run directory)."""

    FILENAME = "archive.sqlite"

    def __init__(self, path: str | Path):
        path = Path(path)
        if path.is_dir() or path.suffix == "":
            path = path / self.FILENAME
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        # one connection; ArchiveWriter may append from its thread, never concurrently
        self._con = sqlite3.connect(str(path), timeout=30.0, check_same_thread=False)
        try:
            self._con.execute("PRAGMA journal_mode=WAL")
            self._con.execute("PRAGMA synchronous=NORMAL")
            self._con.executescript(_SCHEMA)
            self._con.commit()
            self._check_columns()
        except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
            self._con.close()
            raise ValidationError(
                f"{str(path)!r} is not a suspenv run archive (SQLite: {exc})"
            ) from None

    def _check_columns(self) -> None:
        """The evaluations table has the columns this version writes and reads."""
        have = {row[1] for row in self._con.execute("PRAGMA table_info(evaluations)")}
        want = {"batch", "row", "unit", "x", "objectives", "constraints", "ok", "message"}
        if not want <= have:
            raise ValidationError(
                f"{str(self.path)!r} is not a suspenv run archive: its evaluations table "
                f"lacks {sorted(want - have)}"
            )

    # ------------------------------------------------------------------ meta
    def set_meta(self, **items: Any) -> None:
        with self._con:
            self._con.executemany(
                "INSERT OR REPLACE INTO meta(key, value) VALUES (?, ?)",
                [(k, json.dumps(v, default=_json_default)) for k, v in items.items()],
            )

    def meta(self) -> dict[str, Any]:
        out = {}
        for k, v in self._read("SELECT key, value FROM meta"):
            try:
                out[str(k)] = json.loads(v)
            except (TypeError, ValueError):
                raise ValidationError(
                    f"archive {str(self.path)!r}: meta value of {k!r} is not JSON: {v!r:.80}"
                ) from None
        return out

    def _read(self, sql: str, args: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
        """Rows of a query; a damaged file is a ValidationError naming the archive."""
        try:
            return self._con.execute(sql, args).fetchall()
        except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
            raise ValidationError(
                f"archive {str(self.path)!r} is damaged (SQLite: {exc})"
            ) from None

    # --------------------------------------------------------------- appends
    def append(
        self,
        batch_index: int,
        rows: Sequence[int],
        U: np.ndarray,
        X: np.ndarray,
        result: EvaluationBatch,
        wall_time: float,
    ) -> None:
        """Append evaluated designs of one batch (rows = positions inside the batch)."""
        n = len(result)
        if not (len(rows) == n == len(U) == len(X)):
            raise ValidationError(
                f"archive append needs equal lengths, but got rows={len(rows)}, "
                f"U={len(U)}, X={len(X)}, results={n}"
            )
        now = time.time()
        per = wall_time / max(n, 1)
        data = [
            (
                int(batch_index),
                int(rows[i]),
                _blob(U[i]),
                _blob(X[i]),
                _blob(result.objectives[i]),
                _blob(result.constraints[i]),
                int(result.ok[i]),
                result.messages[i],
                per,
                now,
            )
            for i in range(n)
        ]
        with self._con:
            self._con.executemany(
                "INSERT INTO evaluations(batch, row, unit, x, objectives, constraints, ok, "
                "message, wall_time, created) VALUES (?,?,?,?,?,?,?,?,?,?)",
                data,
            )

    # ----------------------------------------------------------------- reads
    def __len__(self) -> int:
        return int(self._read("SELECT COUNT(*) FROM evaluations")[0][0])

    def batch(self, batch_index: int) -> dict[int, tuple[np.ndarray, EvaluationBatch]]:
        """``{row: (unit design, one-row EvaluationBatch)}`` archived for one batch."""
        out: dict[int, tuple[np.ndarray, EvaluationBatch]] = {}
        rows = self._read(
            "SELECT row, unit, objectives, constraints, ok, message FROM evaluations "
            "WHERE batch = ? ORDER BY row",
            (int(batch_index),),
        )
        if not rows:  # the usual case while a run goes on: no meta to read
            return out
        names = {
            str(key): json.loads(value)
            for key, value in self._read(
                "SELECT key, value FROM meta WHERE key IN "
                "('parameter_names', 'objective_names', 'constraint_names')"
            )
        }
        d = len(names.get("parameter_names", [])) or None
        m = len(names.get("objective_names", [])) or None
        k = len(names.get("constraint_names", []))
        for row, u, f, g, ok, msg in rows:
            out[int(row)] = (
                self._values(u, d, "unit"),
                EvaluationBatch(
                    self._values(f, m, "objectives")[None, :],
                    self._values(g, k if names else None, "constraints")[None, :],
                    np.array([bool(ok)]),
                    [str(msg)],
                ),
            )
        return out

    def _values(self, blob: Any, width: int | None, column: str) -> np.ndarray:
        """One row's float64 values from a blob, checked against the expected width."""
        if not isinstance(blob, bytes) or len(blob) % 8:
            raise ValidationError(
                f"archive {str(self.path)!r} is damaged: a {column} value is not float64 data"
            )
        v = _unblob(blob)
        if width is not None and v.size != width:
            raise ValidationError(
                f"archive {str(self.path)!r} is damaged: a {column} value has {v.size} "
                f"numbers, the archive's names say {width}"
            )
        return v

    def arrays(self) -> dict[str, np.ndarray]:
        """Every evaluation in evaluation order (batch, row): unit, x, objectives, constraints,
        ok, message, batch, row, wall_time."""
        rows = self._read(
            "SELECT unit, x, objectives, constraints, ok, message, batch, row, wall_time "
            "FROM evaluations ORDER BY batch, row"
        )
        meta = self.meta()
        d = len(meta.get("parameter_names", [])) or (
            self._values(rows[0][0], None, "unit").size if rows else 0
        )
        m = len(meta.get("objective_names", [])) or (
            self._values(rows[0][2], None, "objectives").size if rows else 0
        )
        k = len(meta.get("constraint_names", []))
        names = ("unit", "x", "objectives", "constraints")

        def stack(col: int, width: int) -> np.ndarray:
            if not rows:
                return np.zeros((0, width))
            return np.vstack([self._values(r[col], width, names[col]) for r in rows])

        return {
            "unit": stack(0, d),
            "x": stack(1, d),
            "objectives": stack(2, m),
            "constraints": stack(3, k) if k else np.zeros((len(rows), 0)),
            "ok": np.array([bool(r[4]) for r in rows], dtype=bool),
            "message": np.array([str(r[5]) for r in rows], dtype=object),
            "batch": self._integers([r[6] for r in rows], "batch"),
            "row": self._integers([r[7] for r in rows], "row"),
            "wall_time": np.array(
                [r[8] if isinstance(r[8], int | float) else np.nan for r in rows], dtype=float
            ),
        }

    def _integers(self, values: list[Any], column: str) -> np.ndarray:
        if not all(isinstance(v, int) for v in values):
            raise ValidationError(
                f"archive {str(self.path)!r} is damaged: a {column} value is not an integer"
            )
        return np.array(values, dtype=int)

    def to_csv(self, path: str | Path) -> Path:
        """Write every evaluation as CSV with named columns; returns the path.

        Numbers are plain decimal text that reads back to the archive's float64 values
        exactly (Python's shortest round-trip form; ``nan``/``inf`` as such), so
        ``pandas.read_csv`` or ``numpy.genfromtxt`` get numeric columns."""
        a = self.arrays()
        meta = self.meta()
        pnames = meta.get("parameter_names") or [f"x{i}" for i in range(a["x"].shape[1])]
        onames = meta.get("objective_names") or [f"f{i}" for i in range(a["objectives"].shape[1])]
        cnames = meta.get("constraint_names") or [f"g{i}" for i in range(a["constraints"].shape[1])]
        path = Path(path)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["batch", "row", *pnames, *onames, *cnames, "ok", "message", "wall_time"])
            for i in range(len(a["ok"])):
                w.writerow(
                    [
                        a["batch"][i],
                        a["row"][i],
                        *map(_number, a["x"][i]),
                        *map(_number, a["objectives"][i]),
                        *map(_number, a["constraints"][i]),
                        int(a["ok"][i]),
                        a["message"][i],
                        f"{a['wall_time'][i]:.6g}",
                    ]
                )
        return path

    def close(self) -> None:
        self._con.close()

    def __enter__(self) -> RunArchive:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ArchiveWriter:
    """Appends chunks to a :class:`RunArchive`, off the hot path where that is safe.

    A chunk whose evaluation took less than :attr:`BACKGROUND_BELOW_S` is committed by a
    background thread while the loop tells the strategy and asks the next batch (SQLite
    releases the GIL while it writes); :meth:`wait` blocks until it is committed, and the
    loop calls it before the next batch is evaluated and before it ends. A slower chunk is
    committed at once. So a kill loses at most the evaluations of one batch that took less
    than that time together (they are evaluated again on resume, with the same result),
    and nothing of an expensive evaluation. A write error is raised by the next call.
    """

    #: evaluations faster than this are written in the background (seconds)
    BACKGROUND_BELOW_S = 0.5

    def __init__(self, archive: RunArchive):
        self.archive = archive
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None

    def append(
        self,
        batch_index: int,
        rows: Sequence[int],
        U: np.ndarray,
        X: np.ndarray,
        result: EvaluationBatch,
        wall_time: float,
    ) -> None:
        """Archive one chunk (see the class docstring for when it is committed)."""
        self.wait()
        args = (batch_index, rows, U, X, result, wall_time)
        if wall_time >= self.BACKGROUND_BELOW_S:
            self.archive.append(*args)
            return

        def write() -> None:
            try:
                self.archive.append(*args)
            except BaseException as exc:  # noqa: BLE001 - handed to the caller by wait()
                self._error = exc

        self._thread = threading.Thread(target=write, name="suspenv-archive", daemon=True)
        self._thread.start()

    def wait(self) -> None:
        """Block until every chunk handed over is committed; raise a write error."""
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._error is not None:
            error, self._error = self._error, None
            raise error


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _number(v: float) -> str:
    """``v`` as decimal text that parses back to the same float64 (shortest round-trip)."""
    return repr(float(v))
