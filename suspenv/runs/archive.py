"""The append-only evaluation archive: one SQLite file per run directory.

The run loop hands every evaluated chunk to an :class:`ArchiveWriter` (group commits:
what a kill loses); :func:`suspenv.runs.loop.optimize` replays the archive to resume
without re-evaluating.
Arrays are stored as little-endian float64 blobs; :meth:`RunArchive.to_csv` writes a flat
table with named columns.

Tables:
    meta(key TEXT PRIMARY KEY, value TEXT)        JSON values: names, config, versions...
    evaluations(id, batch, row, n, unit, x, objectives, constraints, ok, message,
                wall_time, created, checksum)     one row per evaluated chunk

A row of ``evaluations`` holds ``n`` designs of one batch, the batch's rows ``row`` to
``row + n - 1`` (a chunk as the loop evaluated it; rows of a chunk that are not
consecutive, after a resume, make one row per consecutive run): ``unit``, ``x``,
``objectives`` and ``constraints`` are (n, width) arrays, ``ok`` n bytes (1: the
evaluation succeeded), ``message`` a JSON list of n strings, ``wall_time`` the chunk's
evaluation time [s] and ``checksum`` n checksums of 8 bytes. One SQLite row per chunk,
not per design: SQLite's cost is per row (binding, B-tree insert, index), about 3 us,
which per design was a tenth of a cheap CMA-ES generation's time. An archive written
with one row per design (before chunks) is converted when it is first opened, values
unchanged (meta ``chunks_added``: the time).

Durability: SQLite's write-ahead log with ``synchronous=NORMAL``. A commit is durable
against the process being killed (SIGKILL, an out-of-memory kill) as soon as it returns:
the log is in the operating system's file cache. A power loss or an operating-system
crash can undo the commits since the log was last synced (at a checkpoint: every 1000
pages, and when the archive is closed), never leaving a half-written commit; resume
then evaluates those designs again, with the same results.

Integrity: SQLite has no checksum of its pages, so each design carries its own
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

from suspenv.core.atomic import atomic_path, write_fault
from suspenv.core.errors import ValidationError
from suspenv.core.jsonable import json_default
from suspenv.core.result import EvaluationBatch

_META = "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)"
#: the evaluations table (see the module docstring), named by {table}
_EVALUATIONS = """CREATE TABLE IF NOT EXISTS {table} (
    id INTEGER PRIMARY KEY,
    batch INTEGER NOT NULL,
    row INTEGER NOT NULL,
    n INTEGER NOT NULL,
    unit BLOB NOT NULL,
    x BLOB NOT NULL,
    objectives BLOB NOT NULL,
    constraints BLOB NOT NULL,
    ok BLOB NOT NULL,
    message TEXT NOT NULL,
    wall_time REAL NOT NULL,
    created REAL NOT NULL,
    checksum BLOB,
    UNIQUE (batch, row)
)"""
#: the columns written, in :func:`_records`'s order
_COLUMNS = (
    "batch, row, n, unit, x, objectives, constraints, ok, message, wall_time, created, checksum"
)

#: what to do with a damaged archive or one that lost evaluations
_REMEDY = "restore the archive from a copy, or start the run anew with --overwrite"

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
    "SQLITE_READONLY",
    "SQLITE_FULL",
    "SQLITE_CANTOPEN",
    "SQLITE_IOERR",
    "SQLITE_BUSY",
    "SQLITE_LOCKED",
    "SQLITE_PERM",
    "SQLITE_NOMEM",
    "SQLITE_AUTH",
)


def _machine_fault(exc: sqlite3.Error) -> bool:
    """True when SQLite's error is the machine's (:data:`_MACHINE_FAULTS`), not the file's
    content (a damaged header reads as "unsupported file format", also an
    OperationalError)."""
    return str(getattr(exc, "sqlite_errorname", "")).startswith(_MACHINE_FAULTS)


#: the per-design columns a checksum covers, as :func:`table_checksums` takes them
CHECKED = "batch, row, unit, x, objectives, constraints, ok, message"


@functools.lru_cache(maxsize=16)
def _multipliers(width: int) -> np.ndarray:
    """Odd 64-bit multipliers, one per word of a row (fixed: seeded)."""
    rng = np.random.default_rng(0x5EED)
    return rng.integers(0, 2**64, size=width, dtype=np.uint64, endpoint=False) | np.uint64(1)


def _hashes(
    batch: Any, row: Any, ok: Any, message: Sequence[str], columns: Sequence[np.ndarray]
) -> np.ndarray:
    """The (n,) uint64 checksums of :func:`checksums`: each word times its multiplier,
    summed, one matrix-vector product per column (no (n, words) temporary)."""
    n = len(message)
    words = 8 + sum(c.shape[1] for c in columns)
    m = _multipliers(words)
    head = np.empty((n, 8), dtype=np.int64)
    head[:, 0], head[:, 1], head[:, 2] = batch, row, ok
    head[:, 3] = (
        [zlib.crc32(t.encode("utf-8", "surrogatepass")) if t else 0 for t in message]
        if any(message)
        else 0
    )
    head[:, 4:] = [c.shape[1] for c in columns]
    # integer arithmetic wraps modulo 2**64 without a warning (numpy's rule for arrays)
    sums = head.view(np.uint64) @ m[:8]
    j = 8
    for c in columns:
        w = c.shape[1]
        sums += np.ascontiguousarray(c, dtype="<f8").view("<u8") @ m[j : j + w]
        j += w
    return sums


def checksums(
    batch: Sequence[int],
    row: Sequence[int],
    ok: Sequence[int],
    message: Sequence[str],
    columns: Sequence[np.ndarray],
) -> list[bytes]:
    """The 8-byte checksum of each of n designs (see the module docstring): ``columns``
    are the unit, x, objectives and constraints as (n, width) float64 arrays."""
    raw = _hashes(batch, row, ok, message, columns).astype("<u8").tobytes()
    return [raw[i : i + 8] for i in range(0, len(raw), 8)]


def _plausible(row: Sequence[Any]) -> bool:
    """A row of the :data:`CHECKED` columns has the types and sizes suspenv writes."""
    batch, r, unit, x, f, g, ok, message = row
    return (
        all(type(v) is int and -(2**63) <= v < 2**63 for v in (batch, r, ok))
        and type(message) is str
        and all(type(b) is bytes and len(b) % 8 == 0 for b in (unit, x, f, g))
    )


def table_checksums(rows: Sequence[Sequence[Any]]) -> list[bytes | None]:
    """The checksum of each design's :data:`CHECKED` columns as read from the archive,
    designs of equal widths in one :func:`checksums` call; None for a design whose types
    or sizes no suspenv archive writes (never equal to a checksum)."""
    out: list[bytes | None] = [None] * len(rows)
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


def _copy(
    batch_index: int,
    rows: Sequence[int],
    U: np.ndarray,
    X: np.ndarray,
    result: EvaluationBatch,
    wall_time: float,
) -> tuple[Any, ...]:
    """A chunk's values checked and copied (the caller may reuse its arrays), with the
    time it was handed over: the arguments of :func:`_records`."""
    n = len(result)
    if not (len(rows) == n == len(U) == len(X)):
        raise ValidationError(
            f"archive append needs equal lengths, but got rows={len(rows)}, "
            f"U={len(U)}, X={len(X)}, results={n}"
        )
    f8 = [
        np.array(a, dtype="<f8", order="C").reshape(n, -1)
        for a in (U, X, result.objectives, result.constraints)
    ]
    return (
        int(batch_index),
        np.array(rows, dtype=np.int64),
        *f8,
        np.array(result.ok, dtype=np.uint8),
        [str(m) for m in result.messages],
        float(wall_time),
        time.time(),
    )


def _records(
    batch_index: int,
    r: np.ndarray,
    U: np.ndarray,
    X: np.ndarray,
    F: np.ndarray,
    G: np.ndarray,
    ok: np.ndarray,
    msg: list[str],
    wall_time: float,
    now: float,
) -> list[tuple[Any, ...]]:
    """The evaluations table's rows (:data:`_COLUMNS`) of one chunk as :func:`_copy`
    gives it: one per run of consecutive rows ``r`` (one, unless a resume evaluates a
    batch's gaps). The blobs are views of the chunk's arrays (``sqlite3`` binds any
    contiguous buffer; no copy until SQLite's own)."""
    n = len(r)
    if n == 0:
        return []
    cols = (U, X, F, G)
    sums = _hashes(batch_index, r, ok, msg, cols).astype("<u8")
    cuts = [0, *(np.flatnonzero(np.diff(r) != 1) + 1).tolist(), n]
    return [
        (
            batch_index,
            int(r[a]),
            e - a,
            *(c[a:e].data for c in cols),
            ok[a:e].data,
            json.dumps(msg[a:e]),
            wall_time * (e - a) / n,
            now,
            sums[a:e].data,
        )
        for a, e in zip(cuts[:-1], cuts[1:], strict=True)
    ]


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
        self._con = sqlite3.connect(str(path), timeout=30.0, check_same_thread=False)
        try:
            # a new file only (SQLite ignores it once the file has pages): 16 KiB pages take
            # about 25 % less CPU per archived design than the default 4 KiB
            self._con.execute(f"PRAGMA page_size={self.PAGE_SIZE}")
            self._con.execute("PRAGMA journal_mode=WAL")
            self._con.execute("PRAGMA synchronous=NORMAL")
            self._con.execute(_META)
            self._con.execute(_EVALUATIONS.format(table="evaluations"))
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
        if "n" not in have:
            self._to_chunks("checksum" in have)

    def _to_chunks(self, with_checksums: bool) -> None:
        """Convert an archive written with one row per design (before chunks) to one
        design per chunk, values unchanged, in one transaction (meta ``chunks_added``);
        an archive written before rows had checksums gets the checksum of every row as it
        is now (meta ``checksums_added``)."""
        rows = self._con.execute(
            f"SELECT {CHECKED}, wall_time, created, "
            f"{'checksum' if with_checksums else 'NULL'} FROM evaluations ORDER BY id"
        ).fetchall()
        sums = [r[10] for r in rows] if with_checksums else table_checksums([r[:8] for r in rows])
        now = json.dumps(time.strftime("%Y-%m-%d %H:%M:%S"))
        with self._con:
            self._con.execute("BEGIN")
            self._con.execute(_EVALUATIONS.format(table="evaluations_chunks"))
            self._con.executemany(
                f"INSERT INTO evaluations_chunks({_COLUMNS}) VALUES ({', '.join('?' * 12)})",
                [
                    (b, r, 1, u, x, f, g, _one_byte(ok), _one_message(m), t, c, cs)
                    for (b, r, u, x, f, g, ok, m, t, c, _), cs in zip(rows, sums, strict=True)
                ],
            )
            self._con.execute("DROP TABLE evaluations")
            self._con.execute("ALTER TABLE evaluations_chunks RENAME TO evaluations")
            added = ["chunks_added"] + ([] if with_checksums else ["checksums_added"])
            self._con.executemany(
                "INSERT OR REPLACE INTO meta(key, value) VALUES (?, ?)", [(k, now) for k in added]
            )

    def _write(self, sql: str, data: list[tuple[Any, ...]]) -> None:
        """One transaction of ``executemany``; a failed write (a full disk, a read-only
        file) is rolled back and named."""
        try:
            with self._con:
                self._con.executemany(sql, data)
        except sqlite3.OperationalError as exc:
            raise write_fault(self.path, f"SQLite: {exc}") from None

    def _designs(self, where: str, args: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
        """The archived designs of the chunks ``where`` selects, in order of batch and row,
        each checked against its checksum: ``(checksum, *CHECKED columns, wall_time)``."""
        chunks = self._read(
            "SELECT checksum, batch, row, n, unit, x, objectives, constraints, ok, message, "
            f"wall_time FROM evaluations {where} ORDER BY batch, row",
            args,
        )
        rows = [design for chunk in chunks for design in self._split(chunk)]
        self._verify(rows)
        return rows

    def _split(self, chunk: tuple[Any, ...]) -> list[tuple[Any, ...]]:
        """The designs of one chunk row (see :meth:`_designs`); a chunk whose sizes do not
        fit its ``n`` is named damage."""
        checksum, batch, row, n, *blobs, ok, message, wall_time = chunk
        messages = _json_list(message)
        if not (
            type(n) is int
            and 0 < n < 2**32
            and type(row) is int
            and type(ok) is bytes
            and len(ok) == n
            and len(messages) == n
            and all(type(b) is bytes and len(b) % (8 * n) == 0 for b in blobs)
            and (checksum is None or (type(checksum) is bytes and len(checksum) == 8 * n))
        ):
            raise self._damaged(
                f"the evaluations of batch {batch!r} from row {row!r} are not in the layout "
                "suspenv writes"
            )
        w = [len(b) // n for b in blobs]
        each = wall_time / n if isinstance(wall_time, int | float) else None
        return [
            (
                None if checksum is None else checksum[8 * i : 8 * i + 8],
                batch,
                row + i,
                *(b[i * wb : (i + 1) * wb] for b, wb in zip(blobs, w, strict=True)),
                ok[i],
                messages[i],
                each,
            )
            for i in range(n)
        ]

    def _damaged(self, what: str, remedy: bool = True) -> ValidationError:
        """The error of a damaged archive, saying ``what`` is wrong (and, with
        ``remedy``, what to do)."""
        tail = f"; {_REMEDY}" if remedy else ""
        return ValidationError(f"archive {str(self.path)!r} is damaged: {what}{tail}")

    def _verify(self, rows: list[tuple[Any, ...]]) -> None:
        """Each design ``(checksum, *CHECKED columns, ...)`` against its checksum, and no
        design twice (rows in order of batch and row)."""
        sums = table_checksums([r[1:9] for r in rows])
        for (stored, batch, row, *_), c in zip(rows, sums, strict=True):
            if stored is None or stored != c:
                raise self._damaged(
                    f"the evaluation of batch {batch!r}, row {row!r} does not match its "
                    "checksum (a value changed after it was written)"
                )
        keys = [(r[1], r[2]) for r in rows]
        for before, (b, r) in zip(keys, keys[1:], strict=False):
            if (b, r) <= before:
                raise self._damaged(f"it holds the evaluation of batch {b}, row {r} twice")

    def check_count(self, expected: Any, source: str) -> None:
        """Refuse an archive holding fewer evaluations than ``expected`` (what ``source``
        says were evaluated): resuming would evaluate the lost rows again silently."""
        if not isinstance(expected, int) or isinstance(expected, bool):
            return
        have = len(self)
        if have < expected:
            raise ValidationError(
                f"archive {str(self.path)!r} holds {have} evaluation(s), but {source} says "
                f"{expected} were done: evaluations were lost; {_REMEDY}"
            )

    # ------------------------------------------------------------------ meta
    def set_meta(self, **items: Any) -> None:
        self._write(
            "INSERT OR REPLACE INTO meta(key, value) VALUES (?, ?)",
            [(k, json.dumps(v, default=json_default)) for k, v in items.items()],
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
    def append(self, *chunk: *Chunk) -> None:
        """Append one :data:`Chunk` (evaluated designs of one batch; rows = positions
        inside the batch), in one transaction."""
        self.append_chunks([chunk])

    def append_chunks(self, chunks: Sequence[Chunk]) -> None:
        """Append several chunks ``(batch_index, rows, U, X, result, wall_time)`` in one
        transaction: after a crash the archive holds all of them or none."""
        self.insert([r for chunk in chunks for r in _records(*_copy(*chunk))])

    def insert(self, records: list[tuple[Any, ...]]) -> None:
        """Append chunk rows made by :func:`_records`, in one transaction."""
        if records:
            self._write(
                f"INSERT INTO evaluations({_COLUMNS}) VALUES ({', '.join('?' * 12)})", records
            )

    # ----------------------------------------------------------------- reads
    def __len__(self) -> int:
        return int(self._read("SELECT TOTAL(n) FROM evaluations")[0][0])

    def batch(self, batch_index: int) -> dict[int, tuple[np.ndarray, EvaluationBatch]]:
        """``{row: (unit design, one-row EvaluationBatch)}`` archived for one batch."""
        out: dict[int, tuple[np.ndarray, EvaluationBatch]] = {}
        checked = self._designs("WHERE batch = ?", (int(batch_index),))
        if not checked:  # the usual case while a run goes on: no meta to read
            return out
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
            raise self._damaged(f"a {column} value is not float64 data", remedy=False)
        v = np.frombuffer(blob, dtype="<f8")
        if width is not None and v.size != width:
            raise self._damaged(
                f"a {column} value has {v.size} numbers, the archive's names say {width}",
                remedy=False,
            )
        return v

    def arrays(self) -> dict[str, np.ndarray]:
        """Every evaluation in evaluation order (batch, row): unit, x, objectives, constraints,
        ok, message, batch, row, wall_time."""
        rows = self._designs("")
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
            raise self._damaged(f"a {column} value is not an integer", remedy=False)
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
                        *(repr(float(a[key][i, j])) for _, key, j in columns),
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
    machinery or Ctrl-C lose nothing). A cheap batch thus costs copies of its arrays, not
    a transaction: its rows (checksums, views of its arrays) are made when it is
    committed, all pending chunks in one pass. Made at each hand-over, between the
    strategy's own steps, the same few dozen numpy calls took about four times as long
    (caches and branch predictors cold).

    The unit of durability is the group commit: a kill of the process (SIGKILL, an
    out-of-memory kill) loses only the chunks handed over since the last commit, at most
    about :attr:`COMMIT_AFTER_S` seconds of cheap evaluations, never an evaluation that
    took longer; a power loss can also undo the commits since SQLite last synced its log
    (see the module docstring). What is committed is whole chunks in the order evaluated
    (a transaction is all or nothing), so a resumed run replays the archive and evaluates
    exactly what is missing, with the same results.
    """

    #: seconds between group commits; a chunk whose evaluation took longer is committed
    #: as soon as it completes
    COMMIT_AFTER_S = 0.5

    def __init__(self, archive: RunArchive, commit_after_s: float | None = None):
        self.archive = archive
        self.commit_after_s = self.COMMIT_AFTER_S if commit_after_s is None else commit_after_s
        self._pending: list[tuple[Any, ...]] = []  # chunks as _copy gives them
        self._last_commit = time.perf_counter()

    @property
    def pending(self) -> int:
        """Evaluations handed over and not committed yet."""
        return sum(len(c[1]) for c in self._pending)

    def append(self, *chunk: *Chunk) -> None:
        """Archive one :data:`Chunk` (see the class docstring for when it is committed).
        Its values are copied now: the caller may reuse its arrays."""
        now = time.perf_counter()
        self._pending.append(_copy(*chunk))
        if chunk[-1] >= self.commit_after_s or now - self._last_commit >= self.commit_after_s:
            self.flush()

    def flush(self) -> None:
        """Commit every chunk handed over (one transaction). A failed commit (a full
        disk) keeps them pending and raises: nothing is counted as archived that is not."""
        self._last_commit = time.perf_counter()
        if self._pending:
            self.archive.insert([r for c in self._pending for r in _records(*c)])
            self._pending = []


def _one_byte(ok: Any) -> Any:
    """A status of an archive with one row per design as the ``ok`` of a chunk (a value
    suspenv never wrote stays as it is, for the reader to name)."""
    return bytes([ok]) if type(ok) is int and 0 <= ok < 256 else ok


def _one_message(message: Any) -> Any:
    """A message of an archive with one row per design as the ``message`` of a chunk."""
    return json.dumps([message]) if type(message) is str else message


def _json_list(text: Any) -> list[Any]:
    """The list of strings a chunk's ``message`` holds ([] when it holds none)."""
    try:
        value = json.loads(text) if type(text) is str else None
    except ValueError:
        return []
    return value if isinstance(value, list) and all(type(m) is str for m in value) else []
