"""The append-only evaluation archive: one SQLite file per run directory.

The run loop hands every evaluated chunk to an :class:`ArchiveWriter`, which commits them
in group transactions (at most :attr:`ArchiveWriter.COMMIT_AFTER_S` apart, an expensive
chunk at once, everything when the loop ends however it ends), so a run that is killed
loses at most that much cheap work and nothing of an expensive evaluation;
:func:`suspenv.runs.loop.optimize` replays the archive to resume without re-evaluating.
Arrays are stored as little-endian float64 blobs; :meth:`RunArchive.to_csv` writes a flat
table with named columns.

Tables:
    meta(key TEXT PRIMARY KEY, value TEXT)        JSON values: names, config, versions...
    evaluations(id, batch, row, unit, x, objectives, constraints, ok, message,
                wall_time, created, checksum)     one row per evaluated design

Integrity: SQLite has no checksum of its pages, so each row carries its own
(:func:`checksums`: a 64-bit multilinear hash of batch, row, status, the message's
CRC-32, the columns' widths and every 8-byte word of the unit, x, objectives and
constraints; a change confined to one word is always caught, since every word's
multiplier is odd). Every read that results are taken from (the replay
of a resume, :meth:`RunArchive.arrays` behind exports and the CSV) checks it, and a
changed byte is a ValidationError naming the row. An archive written before rows had
checksums gets them when it is first opened (meta ``checksums_added``: the time), and the
count check (:meth:`RunArchive.check_count`) refuses an archive holding fewer rows than
its meta says were evaluated.
"""

from __future__ import annotations

import csv
import functools
import json
import sqlite3
import time
import zlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.result import EvaluationBatch
from suspenv.runs.run_dir import atomic_path, write_fault

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
    checksum BLOB,
    UNIQUE (batch, row)
);
"""

#: value columns of an evaluation: (kind, array of RunArchive.arrays, meta prefix, fallback)
_VALUES = (
    ("design", "x", "parameter", "x"),
    ("objective", "objectives", "objective", "f"),
    ("constraint", "constraints", "constraint", "g"),
)


def value_columns(
    meta: dict[str, Any], arrays: dict[str, np.ndarray]
) -> list[tuple[str, str, int]]:
    """The named value columns of archived evaluations, as ``evaluations.csv`` and
    :func:`suspenv.analysis.load.tidy` write them: (column, array, index).

    ``design:<name> [<unit>]`` (the physical value; unit ``-`` when the problem gives
    none), ``objective:<name> [<unit>]`` (minimised; ``[<unit>]`` when the problem gives
    one) and ``constraint:<name>`` (the constraint's value g, feasible when g <= 0); names
    and units from the archive's meta (``x0``, ``f0``, ``g0``... where it has none)."""
    out = []
    for kind, key, prefix, fallback in _VALUES:
        names = list(meta.get(f"{prefix}_names") or [])
        units = list(meta.get(f"{prefix}_units") or [])
        for j in range(arrays[key].shape[1]):
            name = names[j] if j < len(names) else f"{fallback}{j}"
            unit = units[j] if j < len(units) and units[j] else ("-" if key == "x" else "")
            out.append((f"{kind}:{name}" + (f" [{unit}]" if unit else ""), key, j))
    return out


#: SQLite result codes (prefixes of ``sqlite_errorname``) of a fault of the machine, such
#: as a read-only folder or a full disk; any other error opening an archive is its content's
_MACHINE_FAULTS = (
    "SQLITE_READONLY", "SQLITE_FULL", "SQLITE_CANTOPEN", "SQLITE_IOERR", "SQLITE_BUSY",
    "SQLITE_LOCKED", "SQLITE_PERM", "SQLITE_NOMEM", "SQLITE_AUTH",
)


def _machine_fault(exc: sqlite3.Error) -> bool:
    """True when SQLite's error is the machine's (:data:`_MACHINE_FAULTS`), not the file's
    content (a damaged header reads as "unsupported file format", also an
    OperationalError)."""
    return str(getattr(exc, "sqlite_errorname", "")).startswith(_MACHINE_FAULTS)


#: the columns a row's checksum covers, in :func:`table_checksums`'s order
CHECKED = "batch, row, unit, x, objectives, constraints, ok, message"


@functools.lru_cache(maxsize=16)
def _multipliers(width: int) -> np.ndarray:
    """Odd 64-bit multipliers, one per word of a row (fixed: seeded)."""
    rng = np.random.default_rng(0x5EED)
    return rng.integers(0, 2**64, size=width, dtype=np.uint64, endpoint=False) | np.uint64(1)


def checksums(
    batch: Sequence[int],
    row: Sequence[int],
    ok: Sequence[int],
    message: Sequence[str],
    columns: Sequence[np.ndarray],
) -> list[bytearray]:
    """The 8-byte checksum of each of n rows (see the module docstring): ``columns`` are
    the unit, x, objectives and constraints as (n, width) float64 arrays."""
    n = len(batch)
    crc = [zlib.crc32(m.encode("utf-8", "surrogatepass")) if m else 0 for m in message]
    head = np.array([batch, row, ok, crc], dtype=np.int64).T.reshape(n, 4).view(np.uint64)
    widths = np.repeat(np.array([[c.shape[1] for c in columns]], dtype=np.uint64), n, axis=0)
    words = np.hstack(
        [head, widths, *(np.ascontiguousarray(c, dtype="<f8").view("<u8") for c in columns)]
    )
    # integer arrays wrap modulo 2**64 without a warning (numpy's rule for arrays)
    sums = (words * _multipliers(words.shape[1])).sum(axis=1, dtype=np.uint64)
    return _row_blobs(sums.astype("<u8").reshape(n, 1))


def _plausible(row: Sequence[Any]) -> bool:
    """A row of the :data:`CHECKED` columns has the types and sizes suspenv writes."""
    batch, r, unit, x, f, g, ok, message = row
    return (
        all(type(v) is int and -(2**63) <= v < 2**63 for v in (batch, r, ok))
        and type(message) is str
        and all(type(b) is bytes and len(b) % 8 == 0 for b in (unit, x, f, g))
    )


def table_checksums(rows: Sequence[Sequence[Any]]) -> list[bytearray | None]:
    """The checksum of each row of :data:`CHECKED` columns as read from the table, rows
    of equal widths in one :func:`checksums` call; None for a row whose types or sizes
    no suspenv archive writes (never equal to a checksum)."""
    out: list[bytearray | None] = [None] * len(rows)
    groups: dict[tuple[int, ...], list[int]] = {}
    for i, row in enumerate(rows):
        if _plausible(row):
            groups.setdefault(tuple(len(b) // 8 for b in row[2:6]), []).append(i)
    for widths, idx in groups.items():
        picked = [rows[i] for i in idx]
        cols = [
            np.frombuffer(b"".join(r[2 + j] for r in picked), dtype="<f8").reshape(len(idx), w)
            for j, w in enumerate(widths)
        ]
        sums = checksums(
            [r[0] for r in picked],
            [r[1] for r in picked],
            [r[6] for r in picked],
            [r[7] for r in picked],
            cols,
        )
        for i, c in zip(idx, sums, strict=True):
            out[i] = c
    return out


#: one chunk handed to the archive: (batch index, rows in the batch, U, X, results,
#: seconds the chunk's evaluation took)
Chunk = tuple[int, Sequence[int], np.ndarray, np.ndarray, EvaluationBatch, float]


def _row_blobs(data: np.ndarray) -> list[bytearray]:
    """Each row of the C-contiguous 2-D array ``data`` as its bytes: one copy of the whole
    array, then slices (no numpy call per row). The slices are ``bytearray``: :mod:`sqlite3`
    binds one directly, while a ``bytes`` value first goes through its adapter lookup
    (about 0.4 us per value, five values per row)."""
    n, width = data.shape[0], data.shape[1] * data.itemsize
    raw = bytearray(data)
    return [raw[i : i + width] for i in range(0, n * width, width)] if width else [bytearray()] * n


def _records(
    batch_index: int,
    rows: Sequence[int],
    U: np.ndarray,
    X: np.ndarray,
    result: EvaluationBatch,
    wall_time: float,
    now: float,
) -> list[tuple[Any, ...]]:
    """The evaluations table's rows of one chunk (its columns after ``id``)."""
    n = len(result)
    if not (len(rows) == n == len(U) == len(X)):
        raise ValidationError(
            f"archive append needs equal lengths, but got rows={len(rows)}, "
            f"U={len(U)}, X={len(X)}, results={n}"
        )
    if n == 0:
        return []
    b = [int(batch_index)] * n
    per = float(wall_time) / n
    r = np.asarray(rows, dtype=np.int64).tolist()
    ok = np.asarray(result.ok, dtype=bool).astype(int).tolist()
    msg = [str(m) for m in result.messages]
    cols = [
        np.ascontiguousarray(np.reshape(a, (n, -1)), dtype="<f8")
        for a in (U, X, result.objectives, result.constraints)
    ]
    return list(
        zip(
            b,
            r,
            *(_row_blobs(c) for c in cols),
            ok,
            msg,
            [per] * n,
            [now] * n,
            checksums(b, r, ok, msg, cols),
            strict=True,
        )
    )


def _unblob(b: bytes) -> np.ndarray:
    return np.frombuffer(b, dtype="<f8")


class RunArchive:
    """Append-only SQLite archive of evaluations (``archive.sqlite`` in a run directory)."""

    FILENAME = "archive.sqlite"
    #: SQLite page size of a new archive [bytes]
    PAGE_SIZE = 16384

    def __init__(self, path: str | Path):
        path = Path(path)
        if path.is_dir() or path.suffix == "":
            path = path / self.FILENAME
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        # one connection; ArchiveWriter may append from its thread, never concurrently
        self._con = sqlite3.connect(str(path), timeout=30.0, check_same_thread=False)
        try:
            # a new file only (SQLite ignores it once the file has pages): 16 KiB pages take
            # about 25 % less CPU per archived design than the default 4 KiB
            self._con.execute(f"PRAGMA page_size={self.PAGE_SIZE}")
            self._con.execute("PRAGMA journal_mode=WAL")
            self._con.execute("PRAGMA synchronous=NORMAL")
            self._con.executescript(_SCHEMA)
            self._con.commit()
            self._check_columns()
        except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
            self._con.close()
            if isinstance(exc, sqlite3.OperationalError) and _machine_fault(exc):
                raise write_fault(path, f"SQLite: {exc}") from None
            raise ValidationError(
                f"{str(path)!r} is not a suspenv run archive (SQLite: {exc}); move it "
                "away, or start the run anew with --overwrite"
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
        if "checksum" not in have:
            self._add_checksums()

    def _add_checksums(self) -> None:
        """Migrate an archive written before rows had checksums: add the column and the
        checksum of every row as it is now (meta ``checksums_added`` records when)."""
        rows = self._con.execute(f"SELECT id, {CHECKED} FROM evaluations").fetchall()
        with self._con:
            self._con.execute("ALTER TABLE evaluations ADD COLUMN checksum BLOB")
            self._con.executemany(
                "UPDATE evaluations SET checksum = ? WHERE id = ?",
                [
                    (c, r[0])
                    for c, r in zip(table_checksums([r[1:] for r in rows]), rows, strict=True)
                ],
            )
            self._con.execute(
                "INSERT OR REPLACE INTO meta(key, value) VALUES ('checksums_added', ?)",
                (json.dumps(time.strftime("%Y-%m-%d %H:%M:%S")),),
            )

    def _write(self, sql: str, data: list[tuple[Any, ...]]) -> None:
        """One transaction of ``executemany``; a failed write (a full disk, a read-only
        file) is rolled back and named."""
        try:
            with self._con:
                self._con.executemany(sql, data)
        except sqlite3.OperationalError as exc:
            raise write_fault(self.path, f"SQLite: {exc}") from None

    def _verify(self, rows: list[tuple[Any, ...]]) -> None:
        """Each row ``(checksum, *CHECKED columns, ...)`` against its checksum."""
        sums = table_checksums([r[1:9] for r in rows])
        for (stored, batch, row, *_), c in zip(rows, sums, strict=True):
            if stored is None or stored != c:
                raise ValidationError(
                    f"archive {str(self.path)!r} is damaged: the evaluation of batch "
                    f"{batch!r}, row {row!r} does not match its checksum (a value changed "
                    "after it was written); restore the archive from a copy, or start the "
                    "run anew with --overwrite"
                )

    def check_count(self, expected: Any, source: str) -> None:
        """Refuse an archive holding fewer evaluations than ``expected`` (what ``source``
        says were evaluated): resuming would evaluate the lost rows again silently."""
        if not isinstance(expected, int) or isinstance(expected, bool):
            return
        have = len(self)
        if have < expected:
            raise ValidationError(
                f"archive {str(self.path)!r} holds {have} evaluation(s), but {source} says "
                f"{expected} were done: evaluations were lost; restore the archive from a "
                "copy, or start the run anew with --overwrite"
            )

    # ------------------------------------------------------------------ meta
    def set_meta(self, **items: Any) -> None:
        self._write(
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
        """Append evaluated designs of one batch (rows = positions inside the batch), in one
        transaction."""
        self.append_chunks([(batch_index, rows, U, X, result, wall_time)])

    def append_chunks(self, chunks: Sequence[Chunk]) -> None:
        """Append several chunks ``(batch_index, rows, U, X, result, wall_time)`` in one
        transaction: after a crash the archive holds all of them or none."""
        data: list[tuple[Any, ...]] = []
        now = time.time()
        for chunk in chunks:
            data += _records(*chunk, now)
        self.insert(data)

    def insert(self, records: list[tuple[Any, ...]]) -> None:
        """Append rows made by :func:`_records`, in one transaction."""
        if records:
            self._write(
                f"INSERT INTO evaluations({CHECKED}, wall_time, created, checksum) "
                "VALUES (?,?,?,?,?,?,?,?,?,?,?)",
                records,
            )

    # ----------------------------------------------------------------- reads
    def __len__(self) -> int:
        return int(self._read("SELECT COUNT(*) FROM evaluations")[0][0])

    def batch(self, batch_index: int) -> dict[int, tuple[np.ndarray, EvaluationBatch]]:
        """``{row: (unit design, one-row EvaluationBatch)}`` archived for one batch."""
        out: dict[int, tuple[np.ndarray, EvaluationBatch]] = {}
        checked = self._read(
            f"SELECT checksum, {CHECKED} FROM evaluations WHERE batch = ? ORDER BY row",
            (int(batch_index),),
        )
        if not checked:  # the usual case while a run goes on: no meta to read
            return out
        self._verify(checked)
        rows = [(r[2], r[3], r[5], r[6], r[7], r[8]) for r in checked]
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
            f"SELECT checksum, {CHECKED}, wall_time FROM evaluations ORDER BY batch, row"
        )
        self._verify(rows)
        meta = self.meta()
        self.check_count(meta.get("n_evaluations"), "its meta")
        # column positions in `rows`: 0 checksum, 1 batch, 2 row, 3 unit, 4 x,
        # 5 objectives, 6 constraints, 7 ok, 8 message, 9 wall_time
        d = len(meta.get("parameter_names", [])) or (
            self._values(rows[0][3], None, "unit").size if rows else 0
        )
        m = len(meta.get("objective_names", [])) or (
            self._values(rows[0][5], None, "objectives").size if rows else 0
        )
        k = len(meta.get("constraint_names", []))

        def stack(col: int, width: int, name: str) -> np.ndarray:
            if not rows:
                return np.zeros((0, width))
            return np.vstack([self._values(r[col], width, name) for r in rows])

        return {
            "unit": stack(3, d, "unit"),
            "x": stack(4, d, "x"),
            "objectives": stack(5, m, "objectives"),
            "constraints": stack(6, k, "constraints") if k else np.zeros((len(rows), 0)),
            "ok": np.array([bool(r[7]) for r in rows], dtype=bool),
            "message": np.array([str(r[8]) for r in rows], dtype=object),
            "batch": self._integers([r[1] for r in rows], "batch"),
            "row": self._integers([r[2] for r in rows], "row"),
            "wall_time": np.array(
                [r[9] if isinstance(r[9], int | float) else np.nan for r in rows], dtype=float
            ),
        }

    def _integers(self, values: list[Any], column: str) -> np.ndarray:
        if not all(isinstance(v, int) for v in values):
            raise ValidationError(
                f"archive {str(self.path)!r} is damaged: a {column} value is not an integer"
            )
        return np.array(values, dtype=int)

    def to_csv(self, path: str | Path) -> Path:
        """Write every evaluation as CSV with named columns (:func:`value_columns`; then
        ok, message and the evaluation's wall time in seconds); returns the path.

        Numbers are plain decimal text that reads back to the archive's float64 values
        exactly (Python's shortest round-trip form; ``nan``/``inf`` as such), so
        ``pandas.read_csv`` or ``numpy.genfromtxt`` get numeric columns."""
        a = self.arrays()
        columns = value_columns(self.meta(), a)
        with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(
                ["batch", "row", *(c for c, _, _ in columns), "ok", "message", "wall_time [s]"]
            )
            for i in range(len(a["ok"])):
                w.writerow(
                    [
                        a["batch"][i],
                        a["row"][i],
                        *(_number(a[key][i, j]) for _, key, j in columns),
                        int(a["ok"][i]),
                        a["message"][i],
                        f"{a['wall_time'][i]:.6g}",
                    ]
                )
        return Path(path)

    def close(self) -> None:
        self._con.close()

    def __enter__(self) -> RunArchive:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ArchiveWriter:
    """Hands chunks to a :class:`RunArchive` in group commits, off the hot path.

    Chunks are kept in memory and committed together, in one transaction, when
    :attr:`COMMIT_AFTER_S` seconds have passed since the last commit, at once when a
    chunk's own evaluation took that long or longer, and by :meth:`flush` (the loop calls
    it when it ends, however it ends: a clean stop, an exception, a fault of the
    machinery or Ctrl-C lose nothing). A cheap batch thus costs an append to a list, not
    a transaction. A kill (SIGKILL, power loss) loses only the chunks handed over since
    the last commit: at most about :attr:`COMMIT_AFTER_S` seconds of cheap evaluations,
    never an evaluation that took longer. What is committed is whole chunks in the order
    evaluated (a transaction is all or nothing), so a resumed run replays the archive and
    evaluates exactly what is missing, with the same results.
    """

    #: seconds between group commits; a chunk whose evaluation took longer is committed
    #: as soon as it completes
    COMMIT_AFTER_S = 0.5

    def __init__(self, archive: RunArchive, commit_after_s: float | None = None):
        self.archive = archive
        self.commit_after_s = self.COMMIT_AFTER_S if commit_after_s is None else commit_after_s
        self._pending: list[tuple[Any, ...]] = []  # the archive's rows, made at hand-over
        self._last_commit = time.perf_counter()

    @property
    def pending(self) -> int:
        """Evaluations handed over and not committed yet."""
        return len(self._pending)

    def append(
        self,
        batch_index: int,
        rows: Sequence[int],
        U: np.ndarray,
        X: np.ndarray,
        result: EvaluationBatch,
        wall_time: float,
    ) -> None:
        """Archive one chunk (see the class docstring for when it is committed). Its rows
        are made now (their values are copies: the caller may reuse its arrays)."""
        now = time.perf_counter()
        self._pending += _records(batch_index, rows, U, X, result, wall_time, time.time())
        if wall_time >= self.commit_after_s or now - self._last_commit >= self.commit_after_s:
            self.flush()

    def flush(self) -> None:
        """Commit every chunk handed over (one transaction). A failed commit (a full
        disk) keeps them pending and raises: nothing is counted as archived that is not."""
        self._last_commit = time.perf_counter()
        if self._pending:
            self.archive.insert(self._pending)
            self._pending = []


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
