"""The study store: SQLAlchemy 2 over SQLite (WAL, the embedded default) or PostgreSQL by URL.

Schema changes are Alembic migrations (``migrations/``) applied by :meth:`StudyStore.migrate` at
startup.  Results are stored in blocks (issue 20): one row per chunk of consecutive points, its
results one compact binary blob (``blocks.py``, Arrow IPC), keyed by the chunk's first point and
carrying the content hash of its points.  They are written by one writer, the runner's
coordinator, as chunks complete, as inserts that skip a chunk already stored: a chunk Dask ran
twice is stored once, and a study restarted after a crash plans only the points no stored chunk
covers (by the chunks' places, a few numbers per chunk, never one hash per point).

Cancel and purge may come through any service process on the store.  A chunk is written only
while its study is active and held by the writing coordinator, checked in the chunk's own
transaction: once a cancel has committed, no row of the study is ever written again.  A running
study is cancelled in two steps: ``cancelling`` (asked, by anyone) then ``cancelled`` (its owner
stopped, or the owner is gone); a study is purged only when it is in neither active state.
SQLite with several writers answers "database is locked" (optuna #820, #4994), hence the one
writer; the API's own writes (a new study, a cancel) are single-row and wait on busy_timeout.
"""

from __future__ import annotations

import bisect
import time
from pathlib import Path
from typing import Any, Iterator

import sqlalchemy as sa
from sqlalchemy import event
from sqlalchemy.engine import Engine

from .blocks import Block, decode_rows

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
chunks = sa.Table(
    "study_chunks", metadata,
    sa.Column("study_id", sa.String(36), sa.ForeignKey("studies.id", ondelete="CASCADE"), primary_key=True),
    sa.Column("start", sa.BigInteger, primary_key=True, autoincrement=False),
    sa.Column("n", sa.Integer, nullable=False),
    sa.Column("failed", sa.Integer, nullable=False),
    sa.Column("chunk_hash", sa.String(32), nullable=False),
    sa.Column("data", sa.LargeBinary, nullable=False),
)

_MIGRATIONS = Path(__file__).parent / "migrations"


#: How long an API write waits for SQLite's write lock by default [s] (the service passes its own, inside the
#: request budget: ZWIDTH_STUDY_BUSY_TIMEOUT); the results' writer keeps WRITER_BUSY_TIMEOUT.
BUSY_TIMEOUT = 5.0
WRITER_BUSY_TIMEOUT = 30.0


def _sqlite_pragmas(dbapi_conn, _record, synchronous: str = "FULL", busy_timeout: float = BUSY_TIMEOUT) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")      # readers never block the writer
    cur.execute(f"PRAGMA synchronous={synchronous}")   # FULL: a 202 means the request is on disk
    # the API's single-row writes wait instead of failing, within the request budget (a locked store used to make
    # POST /v1/studies wait 30 s for its 503: issue 28)
    cur.execute(f"PRAGMA busy_timeout={int(busy_timeout * 1000)}")
    cur.execute("PRAGMA foreign_keys=ON")
    if synchronous == "NORMAL":   # the results' writer: a chunk's block spans many pages
        cur.execute("PRAGMA cache_size=-65536")   # 64 MB of page cache instead of 2 MB
    cur.close()


def make_engine(url: str, synchronous: str = "FULL", busy_timeout: float = BUSY_TIMEOUT) -> Engine:
    parsed = sa.engine.make_url(url)
    if parsed.get_backend_name() == "sqlite":
        if parsed.database and parsed.database != ":memory:":
            Path(parsed.database).expanduser().resolve().parent.mkdir(parents=True, exist_ok=True)
        engine = sa.create_engine(url, connect_args={"check_same_thread": False, "timeout": busy_timeout})
        event.listen(engine, "connect", lambda conn, rec: _sqlite_pragmas(conn, rec, synchronous, busy_timeout))
        return engine
    return sa.create_engine(url, pool_pre_ping=True)


#: The advisory lock key of the migrations on PostgreSQL (any fixed 64-bit number: "zwidth" in ASCII).
_MIGRATION_LOCK_KEY = 0x7A7769647468


class _file_lock:
    """An exclusive ``flock`` on ``path`` (created), released on exit or when the process dies."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __enter__(self) -> None:
        import fcntl
        import os

        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
        fcntl.flock(self.fd, fcntl.LOCK_EX)

    def __exit__(self, *exc) -> None:
        import os

        os.close(self.fd)   # closing releases the lock


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

    def __init__(self, url: str, busy_timeout: float = BUSY_TIMEOUT):
        self.url = url
        self.engine = make_engine(url, busy_timeout=busy_timeout)
        name = self.engine.dialect.name
        if name not in ("sqlite", "postgresql"):
            raise ValueError(f"database_url: unsupported database {name!r} (SQLite or PostgreSQL)")
        self._sqlite = name == "sqlite"
        db = sa.engine.make_url(url).database
        # The coordinator's chunks go through their own connection with synchronous=NORMAL (WAL): a commit
        # is not fsynced until the checkpoint.  A power cut may lose the last chunks, never half of one: each
        # chunk's block and its count of done points commit together, and a resumed study recomputes what is
        # missing.  Requests, cancels and states stay FULL: a 202 is on disk.
        self._writer = (make_engine(url, synchronous="NORMAL", busy_timeout=WRITER_BUSY_TIMEOUT) if self._sqlite and db and db != ":memory:"
                        else self.engine)

    def _insert(self):
        if self._sqlite:
            from sqlalchemy.dialects.sqlite import insert
        else:
            from sqlalchemy.dialects.postgresql import insert
        return insert(chunks).on_conflict_do_nothing(index_elements=["study_id", "start"])

    def migrate(self) -> None:
        """Bring the schema to the newest Alembic revision, once: under an exclusive lock, so that service
        processes starting together on a fresh store do not both create the tables (2 of 5 starts of
        ``--workers 2`` on a fresh SQLite file failed with "table studies already exists", and that worker
        answered 503 for life: issue 28).  SQLite: a lock file beside the database (``flock``); PostgreSQL:
        a transaction-level advisory lock."""
        from alembic import command
        from alembic.config import Config

        cfg = Config()
        cfg.set_main_option("script_location", str(_MIGRATIONS))
        with self._migration_lock(), self.engine.begin() as conn:
            if not self._sqlite:
                conn.execute(sa.text("SELECT pg_advisory_xact_lock(:key)"), {"key": _MIGRATION_LOCK_KEY})
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")

    def _migration_lock(self):
        import contextlib

        db = sa.engine.make_url(self.url).database
        if not self._sqlite or not db or db == ":memory:":
            return contextlib.nullcontext()
        return _file_lock(Path(db).expanduser().resolve().with_name(Path(db).name + ".migrate.lock"))

    def count_active(self) -> int:
        """Studies queued or running (the cap of ZWIDTH_STUDY_MAX_ACTIVE counts them)."""
        with self.engine.connect() as conn:
            return int(conn.execute(sa.select(sa.func.count()).select_from(studies)
                                    .where(studies.c.status.in_(ACTIVE))).scalar() or 0)

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
            done, failed = self._counts(conn, study_id)
            conn.execute(studies.update().where(studies.c.id == study_id)
                         .values(status="running", done=done, failed=failed, run_started_at=now, run_start_done=done,
                                 error=None))
        return self.get(study_id)

    @staticmethod
    def _counts(conn, study_id: str) -> tuple[int, int]:
        """(points stored, of which failed) of a study, from its chunks."""
        done, failed = conn.execute(sa.select(sa.func.coalesce(sa.func.sum(chunks.c.n), 0),
                                              sa.func.coalesce(sa.func.sum(chunks.c.failed), 0))
                                    .where(chunks.c.study_id == study_id)).one()
        return int(done), int(failed)

    def stored_chunks(self, study_id: str) -> list[tuple[int, int, str]]:
        """(start, points, content hash) of every stored chunk of the study, by start: a few numbers per chunk
        (a 10-million-point study has some thousands), what a resume plans around."""
        q = (sa.select(chunks.c.start, chunks.c.n, chunks.c.chunk_hash).where(chunks.c.study_id == study_id)
             .order_by(chunks.c.start))
        with self.engine.connect() as conn:
            return [(int(a), int(n), h) for a, n, h in conn.execute(q)]

    def drop_chunks(self, study_id: str, starts: list[int], owner: str | None = None) -> int | None:
        """Delete stale chunks (their points are planned again) as a run starts, and recount (the run starts from
        what is left); None when the study is no longer active or, with ``owner``, no longer held by it."""
        guard = [studies.c.id == study_id, studies.c.status.in_(ACTIVE)]
        if owner is not None:
            guard.append(studies.c.owner == owner)
        with self._writer.begin() as conn:
            if not conn.execute(studies.update().where(*guard).values(done=studies.c.done)).rowcount:
                return None
            gone = 0
            for i in range(0, len(starts), 500):
                gone += conn.execute(chunks.delete().where(chunks.c.study_id == study_id,
                                                           chunks.c.start.in_(starts[i:i + 500]))).rowcount
            done, failed = self._counts(conn, study_id)
            # called as a run starts (runner._run_plan): what the run starts from is what is left
            conn.execute(studies.update().where(studies.c.id == study_id)
                         .values(done=done, failed=failed, run_start_done=done))
        return gone

    def write_chunk(self, study_id: str, block: Block, owner: str | None = None) -> int | None:
        """Store a chunk's block; returns how many points were new (0: that chunk was stored already).

        None, and nothing written, when the study is no longer active (cancelled, purged) or, with
        ``owner``, no longer held by that coordinator: checked by the transaction's first statement,
        which also takes the write lock, so a cancel committed before it is always seen."""
        start, n, failed, digest, data = block[:5]
        guard = [studies.c.id == study_id, studies.c.status.in_(ACTIVE)]
        if owner is not None:
            guard.append(studies.c.owner == owner)
        with self._writer.begin() as conn:
            held = conn.execute(studies.update().where(*guard).values(done=studies.c.done))
            if not held.rowcount:
                return None
            # RETURNING names the row only when it was inserted (a DBAPI's rowcount is not reliable for ON CONFLICT
            # DO NOTHING; psycopg's is not)
            new = conn.execute(self._insert().values(study_id=study_id, start=start, n=n, failed=failed,
                                                     chunk_hash=digest, data=data)
                               .returning(chunks.c.start)).first() is not None
            if new:
                conn.execute(studies.update().where(studies.c.id == study_id)
                             .values(done=studies.c.done + n, failed=studies.c.failed + failed))
        return n if new else 0

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
            conn.execute(chunks.delete().where(chunks.c.study_id == study_id))
            conn.execute(studies.delete().where(studies.c.id == study_id))
        return "deleted"

    # -- results --------------------------------------------------------------------------------
    def _chunk_index(self, conn, study_id: str) -> tuple[list[int], list[int]]:
        """(starts, cumulative point counts before each chunk) of a study's stored chunks, by start."""
        starts, before, total = [], [], 0
        for start, n in conn.execute(sa.select(chunks.c.start, chunks.c.n).where(chunks.c.study_id == study_id)
                                     .order_by(chunks.c.start)):
            starts.append(int(start))
            before.append(total)
            total += int(n)
        before.append(total)
        return starts, before

    def results(self, study_id: str, offset: int = 0, limit: int = 1000) -> list[dict[str, Any]]:
        """Stored points ``offset`` … ``offset + limit − 1`` in point order (an offset counts stored points, as
        rows of a table would): only the chunks holding them are read."""
        with self.engine.connect() as conn:
            starts, before = self._chunk_index(conn, study_id)
            if offset >= before[-1]:
                return []
            first = bisect.bisect_right(before, offset) - 1
            last = bisect.bisect_left(before, offset + limit)      # chunks first … last − 1 hold the page
            out: list[dict[str, Any]] = []
            for k in range(first, min(last, len(starts))):
                data = conn.execute(sa.select(chunks.c.data).where(chunks.c.study_id == study_id,
                                                                   chunks.c.start == starts[k])).scalar_one()
                lo = max(0, offset - before[k])
                hi = min(before[k + 1], offset + limit) - before[k]
                out.extend(decode_rows(starts[k], bytes(data), lo, hi))
        return out

    def iter_blocks(self, study_id: str, batch: int = 16) -> Iterator[tuple[int, bytes]]:
        """(start, block bytes) of every stored chunk in point order, read ``batch`` chunks at a time (keyset on
        start): bounded memory whatever the study's size."""
        last = -1
        while True:
            q = (sa.select(chunks.c.start, chunks.c.data)
                 .where(chunks.c.study_id == study_id, chunks.c.start > last).order_by(chunks.c.start).limit(batch))
            with self.engine.connect() as conn:
                rows = [(int(a), bytes(d)) for a, d in conn.execute(q)]
            if not rows:
                return
            yield from rows
            last = rows[-1][0]

    def iter_results(self, study_id: str, batch: int = 16) -> Iterator[dict[str, Any]]:
        """Every stored result in point order ({idx, params, result, error}), decoded a chunk at a time."""
        for start, data in self.iter_blocks(study_id, batch):
            yield from decode_rows(start, data)
