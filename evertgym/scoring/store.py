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
is never used).

Identification before any write: an existing file is opened only after its header and schema
were read without writing (:func:`identify_store`): an SQLite file stamped with evertgym's
``PRAGMA application_id`` (:data:`APPLICATION_ID`) and this schema version, or a store of this
schema version written before the stamp (a ``trials`` table of these columns, stamped on its first
open, its rows stored before checksums then checksummed).  Anything else (not SQLite, another
application's database, an optuna study, an evertgym store of another version) is refused in one
line and left byte for byte as it was, journal mode included.  A row without a checksum in a
stamped store is refused like an edited one.  A store another process holds locked is waited for
``wait_s`` seconds (:func:`set_default_wait`, the CLI's ``--wait``), then refused as locked.
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
#: ``PRAGMA application_id`` of an evertgym result store ("EVGT"): what identifies a file as ours.
APPLICATION_ID = 0x45564754
#: Seconds a store locked by another process is waited for (:func:`set_default_wait`).
DEFAULT_WAIT_S = 60.0
#: The columns of table ``trials`` (``checksum`` last).
COLUMNS = ("key", "design_name", "group_name", "seed", "trial_index", "success", "spec_json", "result_json", "meta_json",
           "wall_s", "finished_at", "checksum")
_SQLITE_MAGIC = b"SQLite format 3\x00"

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

    def __init__(self, path: str | Path, wait_s: float | None = None) -> None:
        self.path = Path(path)
        wait = DEFAULT_WAIT_S if wait_s is None else float(wait_s)
        kind = identify_store(self.path)  # read-only: a file that is not ours is refused unchanged
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            # isolation_level=None: autocommit, each statement below is its own transaction
            self._db = sqlite3.connect(self.path, timeout=wait, isolation_level=None)
            if kind == "new":  # stamped and made in one transaction, before WAL: the header says what it is
                self._db.execute("BEGIN IMMEDIATE")
                self._db.execute(f"PRAGMA application_id={APPLICATION_ID}")
                self._db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
                self._db.execute(_SCHEMA)
                self._db.execute("ALTER TABLE trials ADD COLUMN checksum TEXT")
                self._db.execute("COMMIT")
            elif kind == "unstamped":  # ours from before the stamp: stamp it, checksum rows stored before checksums
                self._db.execute("BEGIN IMMEDIATE")
                if "checksum" not in {c[1] for c in self._db.execute("PRAGMA table_info(trials)")}:
                    self._db.execute("ALTER TABLE trials ADD COLUMN checksum TEXT")
                rows = list(self._db.execute("SELECT rowid, spec_json, result_json FROM trials WHERE checksum IS NULL"))
                self._db.executemany("UPDATE trials SET checksum = ? WHERE rowid = ?",
                                     [(row_checksum(str(s_), str(r_)), rowid) for rowid, s_, r_ in rows])
                self._db.execute(f"PRAGMA application_id={APPLICATION_ID}")
                self._db.execute("COMMIT")
            else:  # can we write it?  (another process may hold it locked)
                self._db.execute("BEGIN IMMEDIATE")
                self._db.execute("COMMIT")
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")
        except sqlite3.OperationalError as e:
            self._db.close()
            if "locked" in str(e) or "busy" in str(e):
                raise ValueError(f"{self.path}: the store is locked by another process (a run writing it, or an open SQLite "
                                 f"session) and stayed locked for {wait:g} s: let it finish, or pass --wait SECONDS "
                                 "(wait_s= in Python) to wait longer") from None
            raise ValueError(f"{self.path}: cannot open the result store ({e})") from None
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
        out = []
        for rowid, s, r, m, w, t, c in rows:
            delete = f"delete the row (DELETE FROM trials WHERE rowid = {rowid}) to rerun that trial"
            if c is None:
                raise ValueError(f"{self.path}: row {rowid} has no checksum: it was not stored by evertgym; {delete}")
            if not isinstance(s, str) or not isinstance(r, str) or c != row_checksum(s, r):
                raise ValueError(f"{self.path}: row {rowid} fails its checksum: its spec or result was edited after it "
                                 f"was stored; {delete}")
            try:
                out.append(TrialRecord(TrialSpec.from_dict(json.loads(s)), json.loads(r), json.loads(m), w, t))
            except (ValueError, TypeError, KeyError, AttributeError) as e:
                raise ValueError(f"{self.path}: row {rowid} is malformed ({' '.join(str(e).split())[:120]}); {delete}") from None
        return out

    def _query(self, base: str, clauses: list[str], params: list[Any]) -> Iterator[tuple]:
        sql = base + (" WHERE " + " AND ".join(clauses) if clauses else "") + " ORDER BY rowid"
        return self._db.execute(sql, params)


def row_checksum(spec_json: str, result_json: str) -> str:
    """SHA-256 (hex) of a stored row's ``spec_json`` and ``result_json``."""
    return hashlib.sha256(spec_json.encode() + b"\n" + result_json.encode()).hexdigest()


def set_default_wait(seconds: float) -> None:
    """Seconds every :class:`ResultStore` opened afterwards waits for a store another process holds
    locked (the CLI's ``--wait``); :data:`DEFAULT_WAIT_S` until set."""
    global DEFAULT_WAIT_S
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not 0 <= seconds <= 86400:
        raise ValueError(f"--wait = {seconds!r} is out of range: allowed [0, 86400] s")
    DEFAULT_WAIT_S = float(seconds)


def sqlite_header(path: Path) -> tuple[int, int] | None:
    """``(user_version, application_id)`` from an SQLite file's 100-byte header, read as plain bytes
    (no SQLite connection, no lock, nothing written); None if the file is not an SQLite database."""
    with open(path, "rb") as f:
        head = f.read(100)
    if len(head) < 100 or not head.startswith(_SQLITE_MAGIC):
        return None
    return int.from_bytes(head[60:64], "big", signed=True), int.from_bytes(head[68:72], "big", signed=True)


def read_schema(path: Path) -> dict[str, list[str]]:
    """``{table: [columns]}`` of an SQLite file, read without writing to it (:func:`read_database`)."""
    return read_database(path)[2]


def read_database(path: Path) -> tuple[int, int, dict[str, list[str]]]:
    """``(user_version, application_id, {table: [columns]})`` of an SQLite file, opened immutable
    (read-only, no lock, no journal or WAL file made: the file and its journal mode stay as they are).
    With a ``-wal`` file beside it
    (a writer killed before its first checkpoint keeps the schema there), a copy of the two in a
    temporary folder is read instead, so the originals are still never touched."""
    import shutil
    import tempfile
    from urllib.parse import quote

    wal = Path(str(path) + "-wal")
    with tempfile.TemporaryDirectory() as tmp:
        target = path.resolve()
        if wal.is_file() and wal.stat().st_size > 0:
            target = Path(tmp) / "copy.sqlite"
            shutil.copyfile(path, target)
            shutil.copyfile(wal, Path(tmp) / "copy.sqlite-wal")
            uri = f"file:{quote(str(target))}?mode=ro"
        else:
            uri = f"file:{quote(str(target))}?immutable=1"
        db = sqlite3.connect(uri, uri=True)
        try:
            tables = [t for (t,) in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
            schema = {t: [c[1] for c in db.execute(f"PRAGMA table_info({json.dumps(t)})")] for t in tables}
            return (int(db.execute("PRAGMA user_version").fetchone()[0]), int(db.execute("PRAGMA application_id").fetchone()[0]),
                    schema)
        finally:
            db.close()


def identify_store(path: str | Path, flag: str | None = None) -> str:
    """What ``path`` is, found without writing to it: ``"new"`` (missing or empty: a store is made),
    ``"ours"`` (stamped, this schema version) or ``"unstamped"`` (this schema version from before the
    stamp).  Anything else raises ``ValueError`` in one line naming the file (and ``flag``)."""
    path = Path(path)
    name = f"{flag} = {str(path)!r}" if flag else str(path)
    fix = f"pass a new {flag or '--db'} path (the file is left as it is)"
    if not path.exists():
        return "new"
    if path.is_dir():
        raise ValueError(f"{name} is a directory: allowed an evertgym result store (a file)")
    if path.stat().st_size == 0:
        return "new"
    try:
        header = sqlite_header(path)
    except OSError as e:
        raise ValueError(f"{name}: cannot read it ({e.strerror}); {fix}") from None
    if header is None:
        raise ValueError(f"{name} is not an evertgym result store: not an SQLite database; {fix}")
    version, app = header
    if app == APPLICATION_ID:
        if version != SCHEMA_VERSION:
            raise ValueError(f"{name} is an evertgym result store of schema version {version}: allowed version "
                             f"{SCHEMA_VERSION} (written by another evertgym release); {fix}")
        return "ours"
    if app != 0:
        raise ValueError(f"{name} is not an evertgym result store: an SQLite database of another application "
                         f"(application_id {app:#x}); {fix}")
    try:  # (the header can lag behind a WAL file a writer left: the database as SQLite reads it decides)
        version, app, schema = read_database(path)
    except sqlite3.DatabaseError as e:
        raise ValueError(f"{name} is not an evertgym result store: an unreadable SQLite database ({e}); {fix}") from None
    if app == APPLICATION_ID and version == SCHEMA_VERSION:
        return "ours"
    cols = schema.get("trials")
    if set(schema) != {"trials"} or cols is None or not set(COLUMNS[:-1]) <= set(cols) <= set(COLUMNS):
        what = "an optuna study" if {"studies", "version_info"} <= set(schema) else f"tables {sorted(schema)}"
        raise ValueError(f"{name} is not an evertgym result store: an SQLite database with {what}; {fix}")
    if version != SCHEMA_VERSION:
        raise ValueError(f"{name} is an evertgym result store of schema version {version}: allowed version "
                         f"{SCHEMA_VERSION} (an older release wrote it); {fix}")
    return "unstamped"


def identify_study(path: str | Path, flag: str = "--study") -> str:
    """An optuna study file, found without writing to it: ``"new"`` (missing or empty) or ``"optuna"``
    (an SQLite database with optuna's tables ``studies`` and ``version_info``).  Anything else, an
    evertgym result store included, raises ``ValueError`` in one line and is left unchanged."""
    p = Path(path)
    if not p.exists() or (p.is_file() and p.stat().st_size == 0):
        return "new"
    fix = f"pass a new {flag} path (the file is left as it is)"
    if p.is_dir():
        raise ValueError(f"{flag} = {str(path)!r} is a directory: allowed an optuna study file")
    header = sqlite_header(p)
    if header is None:
        raise ValueError(f"{flag} = {str(path)!r} is not an optuna study: not an SQLite database; {fix}")
    if header[1] == APPLICATION_ID:
        raise ValueError(f"{flag} = {str(path)!r} is an evertgym result store, not an optuna study; {fix}")
    try:
        tables = set(read_schema(p))
    except sqlite3.DatabaseError as e:
        raise ValueError(f"{flag} = {str(path)!r} is not an optuna study: an unreadable SQLite database ({e}); {fix}") from None
    if not {"studies", "version_info"} <= tables:
        what = "an evertgym result store" if set(tables) == {"trials"} else f"an SQLite database with tables {sorted(tables)}"
        raise ValueError(f"{flag} = {str(path)!r} is not an optuna study: {what}; {fix}")
    return "optuna"
