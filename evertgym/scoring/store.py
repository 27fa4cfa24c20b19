"""Append-only SQLite store of finished trials, one row per trial, keyed by :attr:`TrialSpec.key`.

Every :meth:`ResultStore.add` is its own committed transaction, so a run killed at any moment
(SIGKILL included) keeps every trial it had stored; at worst the trials in flight are lost
and rerun on resume.  The database runs in WAL mode with ``synchronous=FULL`` (each commit
reaches the disk before ``add`` returns, so even a power cut keeps it).  Rows are never
updated or deleted: adding a key that is already stored is a no-op (``INSERT OR IGNORE``).

Assumptions: the file lives on a local filesystem (WAL needs shared memory, which network
filesystems do not provide); only the runner's parent process writes it, so on a Dask
cluster the workers need no access to it.  Readers (e.g. a progress monitor) may open it
while a run writes.

Columns of table ``trials``: ``key`` (primary key), ``design_name``, ``group_name``, ``seed``,
``trial_index`` and ``success`` (copies for SQL filtering), ``spec_json``, ``result_json``,
``meta_json`` (the run's command, versions, platform: :func:`run_metadata`), ``wall_s``
(the trial's own compute time in s), ``finished_at`` (ISO 8601 UTC) and ``checksum`` (SHA-256
of ``spec_json`` and ``result_json``: :func:`row_checksum`; a row whose checksum does not
match is reported by :meth:`ResultStore.results` with its row number, so an edited result
is never used; rows from before the column have none and are not checked).
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from evertgym.scoring.provenance import run_metadata, utc_now
from evertgym.scoring.spec import TrialResult, TrialSpec, canonical_json, check_result

#: Schema version in ``PRAGMA user_version``; a store with another version is refused.
SCHEMA_VERSION = 1

_SCHEMA = """
CREATE TABLE IF NOT EXISTS trials (
    key TEXT PRIMARY KEY,
    design_name TEXT NOT NULL,
    group_name TEXT NOT NULL,
    seed INTEGER NOT NULL,
    trial_index INTEGER NOT NULL,
    success INTEGER NOT NULL,
    spec_json TEXT NOT NULL,
    result_json TEXT NOT NULL,
    meta_json TEXT NOT NULL,
    wall_s REAL,
    finished_at TEXT NOT NULL
)
"""

#: Filters accepted by :meth:`ResultStore.results`, and the column each one reads.
FILTER_COLUMNS = {
    "design_name": "design_name",
    "group": "group_name",
    "seed": "seed",
    "index": "trial_index",
    "success": "success",
}

#: Keys per ``IN (...)`` clause, well below SQLite's limit on bound parameters.
_CHUNK = 500


@dataclass(frozen=True)
class TrialRecord:
    """A stored trial: its spec, its result, the run metadata, compute time (s) and finish time."""

    spec: TrialSpec
    result: TrialResult
    meta: dict[str, Any]
    wall_s: float | None
    finished_at: str

    @property
    def key(self) -> str:
        """The trial's key (:attr:`TrialSpec.key`)."""
        return self.spec.key


class ResultStore:
    """An append-only SQLite file of trial results (created if missing).

    Use as a context manager or call :meth:`close`.  Not shared between threads: the
    connection belongs to the thread that opened the store.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # isolation_level=None: autocommit, each statement below is its own transaction
        try:
            self._db = sqlite3.connect(self.path, timeout=60.0, isolation_level=None)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")
            version = self._db.execute("PRAGMA user_version").fetchone()[0]
            tables = {t for (t,) in self._db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        except sqlite3.DatabaseError as e:
            raise ValueError(f"{self.path}: not a result store ({e}); pass a new --db path or move the file away") from None
        if version not in (0, SCHEMA_VERSION) or (tables and "trials" not in tables):
            self._db.close()
            raise ValueError(f"{self.path}: not an evertgym result store (schema version {version}, tables "
                             f"{sorted(tables)}): allowed version {SCHEMA_VERSION} with table 'trials'; pass a new --db path")
        self._db.execute(_SCHEMA)
        if "checksum" not in {c[1] for c in self._db.execute("PRAGMA table_info(trials)")}:
            self._db.execute("ALTER TABLE trials ADD COLUMN checksum TEXT")
        self._db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        self._default_meta: dict[str, Any] | None = None

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the database connection (every added row is already committed)."""
        self._db.close()

    def __len__(self) -> int:
        return self._db.execute("SELECT COUNT(*) FROM trials").fetchone()[0]

    def fingerprints(self, keys: Iterable[str]) -> dict[str, str | None]:
        """The ``code_fingerprint`` of the run that computed each stored trial of ``keys``
        (None where the run did not record one)."""
        keys = list(keys)
        out: dict[str, str | None] = {}
        for i in range(0, len(keys), _CHUNK):
            chunk = keys[i:i + _CHUNK]
            rows = self._db.execute(
                f"SELECT key, meta_json FROM trials WHERE key IN ({','.join('?' * len(chunk))})", chunk)
            out.update((k, json.loads(m).get("code_fingerprint")) for k, m in rows)
        return out

    def done_keys(self) -> set[str]:
        """Keys of every stored trial."""
        return {k for (k,) in self._db.execute("SELECT key FROM trials")}

    def add(
        self,
        spec: TrialSpec,
        result: Mapping[str, Any],
        *,
        wall_s: float | None = None,
        meta: Mapping[str, Any] | None = None,
    ) -> bool:
        """Store one finished trial and commit; return False (and change nothing) if its key is stored.

        ``result`` is validated by :func:`check_result` (raising :class:`TrialResultError`);
        ``wall_s`` is the trial's compute time in s; ``meta`` defaults to one
        :func:`run_metadata` made for this store object.
        """
        plain = check_result(result)
        if meta is None:
            if self._default_meta is None:
                self._default_meta = run_metadata()
            meta = self._default_meta
        cur = self._db.execute(
            "INSERT OR IGNORE INTO trials (key, design_name, group_name, seed, trial_index, success,"
            " spec_json, result_json, meta_json, wall_s, finished_at, checksum) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (
                spec.key,
                spec.design_name,
                spec.group,
                spec.seed,
                spec.index,
                int(plain["success"]),
                canonical_json(spec.to_dict()),
                canonical_json(plain),
                canonical_json(dict(meta)),
                None if wall_s is None else float(wall_s),
                utc_now(),
                row_checksum(canonical_json(spec.to_dict()), canonical_json(plain)),
            ),
        )
        return cur.rowcount == 1

    def results(self, keys: Iterable[str] | None = None, **where: Any) -> list[TrialRecord]:
        """Stored trials in the order they were stored, optionally filtered.

        ``keys`` keeps only those keys; each ``where`` filter (``design_name``, ``group``,
        ``seed``, ``index``, ``success``) takes a value or a list/tuple/set of values, e.g.
        ``results(design_name=["bare", "b30"], success=True)``.
        """
        clauses, params = [], []
        for name, value in where.items():
            if name not in FILTER_COLUMNS:
                raise ValueError(f"unknown results filter {name!r}: allowed {', '.join(FILTER_COLUMNS)}")
            values = list(value) if isinstance(value, (list, tuple, set, frozenset)) else [value]
            values = [int(v) if name == "success" else v for v in values]
            clauses.append(f"{FILTER_COLUMNS[name]} IN ({', '.join('?' * len(values))})")
            params.extend(values)
        base = "SELECT rowid, spec_json, result_json, meta_json, wall_s, finished_at, checksum FROM trials"
        if keys is None:
            rows = list(self._query(base, clauses, params))
        else:
            keys = list(dict.fromkeys(keys))
            rows = []
            for i in range(0, len(keys), _CHUNK):
                chunk = keys[i : i + _CHUNK]
                in_keys = f"key IN ({', '.join('?' * len(chunk))})"
                rows.extend(self._query(base, [in_keys, *clauses], [*chunk, *params]))
            rows.sort(key=lambda row: row[0])
        for rowid, s, r, _, _, _, c in rows:
            if c is not None and c != row_checksum(s, r):
                raise ValueError(f"{self.path}: row {rowid} fails its checksum: its spec or result was edited after it "
                                 f"was stored; delete the row (DELETE FROM trials WHERE rowid = {rowid}) to rerun that trial")
        return [
            TrialRecord(TrialSpec.from_dict(json.loads(s)), json.loads(r), json.loads(m), w, t)
            for _, s, r, m, w, t, _ in rows
        ]

    def _query(self, base: str, clauses: list[str], params: list[Any]) -> Iterator[tuple]:
        sql = base + (" WHERE " + " AND ".join(clauses) if clauses else "") + " ORDER BY rowid"
        return self._db.execute(sql, params)


def row_checksum(spec_json: str, result_json: str) -> str:
    """SHA-256 (hex) of a stored row's ``spec_json`` and ``result_json``."""
    return hashlib.sha256(spec_json.encode() + b"\n" + result_json.encode()).hexdigest()
