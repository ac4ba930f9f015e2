"""The study store: SQLAlchemy 2 over SQLite (WAL, the embedded default) or PostgreSQL by URL.

Schema changes are Alembic migrations (``migrations/``) applied by :meth:`StudyStore.migrate` at
startup.  Results are written by one writer, the runner's coordinator, in chunks as they
complete, as inserts that skip a point already stored (keyed by the point's content hash): a
study restarted after a crash, or a chunk Dask ran twice, never stores a point twice.

Cancel and purge may come through any service process on the store.  A chunk is written only
while its study is active and held by the writing coordinator, checked in the chunk's own
transaction: once a cancel has committed, no row of the study is ever written again.  A running
study is cancelled in two steps: ``cancelling`` (asked, by anyone) then ``cancelled`` (its owner
stopped, or the owner is gone); a study is purged only when it is in neither active state.
SQLite with several writers answers "database is locked" (optuna #820, #4994), hence the one
writer; the API's own writes (a new study, a cancel) are single-row and wait on busy_timeout.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Iterable, Iterator

import sqlalchemy as sa
from sqlalchemy import event
from sqlalchemy.engine import Engine

from .encode import EncodedRows, encode_rows

__all__ = ["StudyStore", "ACTIVE", "FINISHED", "CANCELLING"]

ACTIVE = ("queued", "running")
#: A coordinator renews its lease on the study it runs well within this time [s]; a study whose
#: lease ran out (its process is gone) may be taken over by another service process.
LEASE_SECONDS = 30.0
FINISHED = ("done", "cancelled", "failed")
#: A cancel asked while a coordinator runs the study; the owner turns it into "cancelled" when it stops.
CANCELLING = "cancelling"

metadata = sa.MetaData()
studies = sa.Table(
    "studies", metadata,
    sa.Column("id", sa.String(36), primary_key=True),
    sa.Column("problem", sa.String(32), nullable=False),
    sa.Column("request", sa.JSON, nullable=False),
    sa.Column("status", sa.String(16), nullable=False),
    sa.Column("total", sa.Integer, nullable=False),
    sa.Column("done", sa.Integer, nullable=False),
    sa.Column("failed", sa.Integer, nullable=False),
    sa.Column("created_at", sa.Float, nullable=False),
    sa.Column("run_started_at", sa.Float),
    sa.Column("run_start_done", sa.Integer, nullable=False),
    sa.Column("finished_at", sa.Float),
    sa.Column("error", sa.Text),
    sa.Column("owner", sa.String(128)),
    sa.Column("lease_until", sa.Float),
    sa.Index("ix_studies_status_created", "status", "created_at"),
)
results = sa.Table(
    "study_results", metadata,
    sa.Column("study_id", sa.String(36), sa.ForeignKey("studies.id", ondelete="CASCADE"), primary_key=True),
    sa.Column("point_hash", sa.String(32), primary_key=True),
    sa.Column("idx", sa.Integer, nullable=False),
    sa.Column("params", sa.JSON, nullable=False),
    sa.Column("result", sa.JSON),
    sa.Column("error", sa.Text),
    sa.Index("ix_study_results_idx", "study_id", "idx"),
)

_MIGRATIONS = Path(__file__).parent / "migrations"


def _sqlite_pragmas(dbapi_conn, _record, synchronous: str = "FULL") -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")      # readers never block the writer
    cur.execute(f"PRAGMA synchronous={synchronous}")   # FULL: a 202 means the request is on disk
    cur.execute("PRAGMA busy_timeout=30000")    # the API's single-row writes wait instead of failing
    cur.execute("PRAGMA foreign_keys=ON")
    if synchronous == "NORMAL":   # the results' writer: its inserts land in two text-keyed indexes at random
        cur.execute("PRAGMA cache_size=-65536")   # places: 64 MB of page cache instead of 2 MB
    cur.close()


def make_engine(url: str, synchronous: str = "FULL") -> Engine:
    parsed = sa.engine.make_url(url)
    if parsed.get_backend_name() == "sqlite":
        if parsed.database and parsed.database != ":memory:":
            Path(parsed.database).expanduser().resolve().parent.mkdir(parents=True, exist_ok=True)
        engine = sa.create_engine(url, connect_args={"check_same_thread": False, "timeout": 30})
        event.listen(engine, "connect", lambda conn, rec: _sqlite_pragmas(conn, rec, synchronous))
        return engine
    return sa.create_engine(url, pool_pre_ping=True)


_INSERT_SQLITE = ("INSERT INTO study_results (study_id, idx, point_hash, params, result, error) "
                  "VALUES (?, ?, ?, ?, ?, ?) ON CONFLICT (study_id, point_hash) DO NOTHING")


def _insert_sqlite(conn, study_id: str, rows: EncodedRows) -> tuple[int, int]:
    """(new results, new failures): one executemany of encoded rows on the transaction's own DBAPI
    connection (SQLAlchemy's per-row parameter processing cost as much as the numerics); the new rows are
    counted by the connection's change counter (a skipped duplicate changes nothing)."""
    raw = conn.connection.dbapi_connection
    cur = raw.cursor()
    counts = []
    for part in ([r for r in rows if r[4] is None], [r for r in rows if r[4] is not None]):
        if not part:
            counts.append(0)
            continue
        before = raw.total_changes
        cur.executemany(_INSERT_SQLITE, [(study_id, *r) for r in part])
        counts.append(raw.total_changes - before)
    cur.close()
    return counts[0], counts[1]


def _same(column, value):
    return column.is_(None) if value is None else column == value


def _alive_here(owner: str) -> bool | None:
    """Whether the process named by an owner id "host:pid:…" on this host is alive (None: another host)."""
    import os
    import socket

    host, _, rest = owner.partition(":")
    pid = rest.partition(":")[0]
    if host != socket.gethostname() or not pid.isdigit():
        return None
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _alive_owner(cur: tuple, now: float) -> bool:
    """Whether the owner of a (owner, lease_until) pair may still write: its lease runs and, on this
    host, its process exists."""
    owner, lease = cur
    if lease is None or lease < now:
        return False
    return _alive_here(owner) is not False


def _claimable(current: str | None, lease_until: float | None, owner: str, now: float) -> bool:
    """Free, ours, expired, or held by a process of this host that is gone (a restart after a crash)."""
    if current is None or current == owner or lease_until is None or lease_until < now:
        return True
    return _alive_here(current) is False


class StudyStore:
    """Studies and their results in one database (see the module docstring for who writes what)."""

    def __init__(self, url: str):
        self.url = url
        self.engine = make_engine(url)
        self._insert = self._insert_factory()
        self._sqlite = self.engine.dialect.name == "sqlite"
        db = sa.engine.make_url(url).database
        # The coordinator's chunks go through their own connection with synchronous=NORMAL (WAL): a commit
        # is not fsynced until the checkpoint.  A power cut may lose the last chunks, never half of one: each
        # chunk's rows and its count of done points commit together, and a resumed study recomputes what is
        # missing (exactly once, by hash).  Requests, cancels and states stay FULL: a 202 is on disk.
        self._writer = (make_engine(url, synchronous="NORMAL") if self._sqlite and db and db != ":memory:"
                        else self.engine)

    def _insert_factory(self):
        name = self.engine.dialect.name
        if name == "sqlite":
            from sqlalchemy.dialects.sqlite import insert
        elif name == "postgresql":
            from sqlalchemy.dialects.postgresql import insert
        else:
            raise ValueError(f"database_url: unsupported database {name!r} (SQLite or PostgreSQL)")
        # RETURNING lists only the rows really inserted: the count of new points on both databases
        # (a DBAPI's executemany rowcount is not reliable for ON CONFLICT DO NOTHING; psycopg's is not).
        return lambda: (insert(results).on_conflict_do_nothing(index_elements=["study_id", "point_hash"])
                        .returning(results.c.point_hash))

    def migrate(self) -> None:
        """Bring the schema to the newest Alembic revision."""
        from alembic import command
        from alembic.config import Config

        cfg = Config()
        cfg.set_main_option("script_location", str(_MIGRATIONS))
        with self.engine.begin() as conn:
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")

    def dispose(self) -> None:
        self.engine.dispose()
        if self._writer is not self.engine:
            self._writer.dispose()

    # -- studies --------------------------------------------------------------------------------
    def create(self, study_id: str, problem: str, request: dict, total: int) -> dict:
        row = dict(id=study_id, problem=problem, request=request, status="queued", total=total, done=0,
                   failed=0, created_at=time.time(), run_started_at=None, run_start_done=0, finished_at=None,
                   error=None, owner=None, lease_until=None)
        with self.engine.begin() as conn:
            conn.execute(studies.insert().values(**row))
        return row

    def get(self, study_id: str) -> dict | None:
        with self.engine.connect() as conn:
            row = conn.execute(studies.select().where(studies.c.id == study_id)).mappings().first()
        return dict(row) if row else None

    def list(self, limit: int = 100, offset: int = 0, status: str | None = None) -> list[dict]:
        q = studies.select().order_by(studies.c.created_at.desc(), studies.c.id).limit(limit).offset(offset)
        if status:
            q = q.where(studies.c.status == status)
        with self.engine.connect() as conn:
            return [dict(r) for r in conn.execute(q).mappings()]

    def active_ids(self, owner: str | None = None) -> list[str]:
        """Studies to run or to resume, oldest first (with ``owner``: those it may claim)."""
        q = sa.select(studies.c.id, studies.c.owner, studies.c.lease_until).where(studies.c.status.in_(ACTIVE)) \
            .order_by(studies.c.created_at, studies.c.id)
        with self.engine.connect() as conn:
            rows = conn.execute(q).all()
        if owner is None:
            return [r[0] for r in rows]
        now = time.time()
        return [r[0] for r in rows if _claimable(r[1], r[2], owner, now)]

    def renew(self, study_id: str, owner: str) -> bool:
        """Extend ``owner``'s lease; False when the study is no longer its own (or no longer active)."""
        with self.engine.begin() as conn:
            res = conn.execute(studies.update().where(studies.c.id == study_id, studies.c.owner == owner,
                                                      studies.c.status.in_(ACTIVE))
                               .values(lease_until=time.time() + LEASE_SECONDS))
        return bool(res.rowcount)

    def status(self, study_id: str) -> str | None:
        with self.engine.connect() as conn:
            return conn.execute(sa.select(studies.c.status).where(studies.c.id == study_id)).scalar()

    def begin_run(self, study_id: str, owner: str = "") -> dict | None:
        """Claim the study for ``owner``, count what is stored, mark it running.

        None when it is no longer active, or another live coordinator holds it.
        """
        now = time.time()
        with self.engine.begin() as conn:
            cur = conn.execute(sa.select(studies.c.owner, studies.c.lease_until)
                               .where(studies.c.id == study_id, studies.c.status.in_(ACTIVE))).first()
            if cur is None or not _claimable(cur[0], cur[1], owner, now):
                return None
            # Compare-and-set on the owner seen above: two coordinators cannot both win.
            claim = conn.execute(studies.update().where(studies.c.id == study_id, studies.c.status.in_(ACTIVE),
                                                        _same(studies.c.owner, cur[0]))
                                 .values(owner=owner, lease_until=now + LEASE_SECONDS))
            if not claim.rowcount:
                return None
            done = conn.execute(sa.select(sa.func.count()).select_from(results)
                                .where(results.c.study_id == study_id)).scalar_one()
            failed = conn.execute(sa.select(sa.func.count()).select_from(results)
                                  .where(results.c.study_id == study_id, results.c.error.is_not(None))).scalar_one()
            conn.execute(studies.update().where(studies.c.id == study_id)
                         .values(status="running", done=done, failed=failed, run_started_at=now, run_start_done=done,
                                 error=None))
        return self.get(study_id)

    def stored_hashes(self, study_id: str) -> set[str]:
        with self.engine.connect() as conn:
            return set(conn.execute(sa.select(results.c.point_hash).where(results.c.study_id == study_id)).scalars())

    def write_chunk(self, study_id: str, rows: Iterable[tuple], owner: str | None = None) -> int | None:
        """Store (index, hash, params, result, error) rows; returns how many were new.  ``rows`` may come
        encoded (``EncodedRows``: params and result as JSON text, encoded in the worker).

        None, and nothing written, when the study is no longer active (cancelled, purged) or, with
        ``owner``, no longer held by that coordinator: checked by the transaction's first statement,
        which also takes the write lock, so a cancel committed before it is always seen."""
        if not isinstance(rows, EncodedRows):
            rows = encode_rows(list(rows))
        guard = [studies.c.id == study_id, studies.c.status.in_(ACTIVE)]
        if owner is not None:
            guard.append(studies.c.owner == owner)
        with self._writer.begin() as conn:
            held = conn.execute(studies.update().where(*guard).values(done=studies.c.done))
            if not held.rowcount:
                return None
            if self._sqlite:
                new_ok, new_bad = _insert_sqlite(conn, study_id, rows)
            else:
                new_ok, new_bad = self._insert_rows(conn, study_id, rows)
            if new_ok or new_bad:
                conn.execute(studies.update().where(studies.c.id == study_id)
                             .values(done=studies.c.done + new_ok + new_bad, failed=studies.c.failed + new_bad))
        return new_ok + new_bad

    def _insert_rows(self, conn, study_id: str, rows: EncodedRows) -> tuple[int, int]:
        """(new results, new failures) inserted through SQLAlchemy (PostgreSQL: its JSON columns take objects)."""
        ok, bad = [], []
        for index, digest, params, result, error in rows:
            rec = dict(study_id=study_id, point_hash=digest, idx=index, params=json.loads(params),
                       result=json.loads(result), error=error)
            (bad if error is not None else ok).append(rec)
        new_ok = len(conn.execute(self._insert(), ok).all()) if ok else 0
        new_bad = len(conn.execute(self._insert(), bad).all()) if bad else 0
        return new_ok, new_bad

    def set_error(self, study_id: str, error: str) -> None:
        """Say why an active study is not progressing (cleared when a run starts)."""
        with self.engine.begin() as conn:
            conn.execute(studies.update().where(studies.c.id == study_id).values(error=error))

    def finish(self, study_id: str, status: str, error: str | None = None, owner: str | None = None) -> None:
        """Close a running study (a cancel that came first wins: a ``cancelling`` study becomes ``cancelled``);
        with ``owner``, only while that coordinator holds it."""
        guard = [studies.c.id == study_id, studies.c.status.in_(("running", CANCELLING))]
        if owner is not None:
            guard.append(studies.c.owner == owner)
        with self.engine.begin() as conn:
            conn.execute(studies.update().where(*guard)
                         .values(status=sa.case((studies.c.status == CANCELLING, "cancelled"), else_=status),
                                 finished_at=time.time(), error=sa.case((studies.c.status == CANCELLING, None),
                                                                        else_=error),
                                 owner=None, lease_until=None))

    def cancel(self, study_id: str) -> str | None:
        """Cancel an active study: "cancelled" at once when nobody runs it (queued, or its owner is gone),
        "cancelling" when a live coordinator runs it (it stops at its next chunk and says "cancelled");
        None when the study is not active.  From the commit on, no row of the study is written."""
        now = time.time()
        with self.engine.begin() as conn:
            res = conn.execute(studies.update().where(studies.c.id == study_id, studies.c.status == "queued")
                               .values(status="cancelled", finished_at=now))
            if res.rowcount:
                return "cancelled"
            cur = conn.execute(sa.select(studies.c.owner, studies.c.lease_until)
                               .where(studies.c.id == study_id, studies.c.status == "running")).first()
            if cur is None:
                return None
            gone = cur[0] is None or not _alive_owner(tuple(cur), now)
            res = conn.execute(studies.update().where(studies.c.id == study_id, studies.c.status == "running",
                                                      _same(studies.c.owner, cur[0]))
                               .values(**({"status": "cancelled", "finished_at": now, "owner": None,
                                           "lease_until": None} if gone else {"status": CANCELLING})))
            if not res.rowcount:   # the owner changed meanwhile: say what the store now holds
                return conn.execute(sa.select(studies.c.status).where(studies.c.id == study_id)).scalar()
            return "cancelled" if gone else CANCELLING

    def settle_cancels(self) -> int:
        """Turn ``cancelling`` studies whose owner is gone (crashed, lease run out) into ``cancelled``."""
        now = time.time()
        with self.engine.connect() as conn:
            rows = conn.execute(sa.select(studies.c.id, studies.c.owner, studies.c.lease_until)
                                .where(studies.c.status == CANCELLING)).all()
        settled = 0
        for sid, owner, lease in rows:
            if owner is None or not _alive_owner((owner, lease), now):
                with self.engine.begin() as conn:
                    settled += conn.execute(
                        studies.update().where(studies.c.id == sid, studies.c.status == CANCELLING,
                                               _same(studies.c.owner, owner))
                        .values(status="cancelled", finished_at=now, owner=None, lease_until=None)).rowcount
        return settled

    def delete(self, study_id: str) -> str:
        """Purge a study and its results: "deleted", "missing", or "active" (refused: queued, running or
        cancelling — a coordinator may still write; cancel it and purge once it is cancelled)."""
        with self.engine.begin() as conn:
            # The guard is the first write: a coordinator's chunk transaction cannot interleave.
            res = conn.execute(studies.update().where(studies.c.id == study_id, studies.c.status.in_(FINISHED))
                               .values(owner=None))
            if not res.rowcount:
                exists = conn.execute(sa.select(studies.c.id).where(studies.c.id == study_id)).first()
                return "active" if exists else "missing"
            conn.execute(results.delete().where(results.c.study_id == study_id))
            conn.execute(studies.delete().where(studies.c.id == study_id))
        return "deleted"

    # -- results --------------------------------------------------------------------------------
    def results(self, study_id: str, offset: int = 0, limit: int = 1000) -> list[dict[str, Any]]:
        q = (sa.select(results.c.idx, results.c.params, results.c.result, results.c.error)
             .where(results.c.study_id == study_id).order_by(results.c.idx).offset(offset).limit(limit))
        with self.engine.connect() as conn:
            return [dict(r) for r in conn.execute(q).mappings()]

    def iter_results(self, study_id: str, batch: int = 5000) -> Iterator[dict[str, Any]]:
        """Every stored result in point order, read in batches (keyset on idx)."""
        last = -1
        while True:
            q = (sa.select(results.c.idx, results.c.params, results.c.result, results.c.error)
                 .where(results.c.study_id == study_id, results.c.idx > last).order_by(results.c.idx).limit(batch))
            with self.engine.connect() as conn:
                rows = [dict(r) for r in conn.execute(q).mappings()]
            if not rows:
                return
            yield from rows
            last = rows[-1]["idx"]
