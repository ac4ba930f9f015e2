"""The study store: Alembic schema equals the code's tables, WAL, idempotent chunk writes."""

from __future__ import annotations

import sqlalchemy as sa
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from service.studies.store import StudyStore, metadata


def _store(tmp_path) -> StudyStore:
    store = StudyStore(f"sqlite:///{tmp_path / 'deep' / 'dir' / 's.db'}")  # parent directories are created
    store.migrate()
    store.migrate()  # idempotent: a restart applies nothing twice
    return store


def test_migrations_give_the_schema_the_code_uses(tmp_path):
    store = _store(tmp_path)
    with store.engine.connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), metadata)
        assert diff == []
        assert conn.execute(sa.text("PRAGMA journal_mode")).scalar() == "wal"
        assert conn.execute(sa.text("SELECT version_num FROM alembic_version")).scalar() == "0002"


def test_chunks_are_written_once(tmp_path):
    store = _store(tmp_path)
    store.create("s1", "stability", {"sweep": {}}, total=3)
    rows = [(0, "a" * 32, [1.0], {"k": 1.0}, None), (1, "b" * 32, [2.0], None, "bad point")]
    assert store.write_chunk("s1", rows) == 2
    assert store.write_chunk("s1", rows) == 0  # a chunk Dask ran twice changes nothing
    row = store.get("s1")
    assert (row["done"], row["failed"]) == (2, 1)
    assert store.stored_hashes("s1") == {"a" * 32, "b" * 32}
    assert [r["idx"] for r in store.iter_results("s1", batch=1)] == [0, 1]
    # a restart recounts from the rows themselves
    assert store.begin_run("s1")["done"] == 2 and store.get("s1")["status"] == "running"


def test_cancel_wins_over_finish(tmp_path):
    store = _store(tmp_path)
    store.create("s2", "stability", {}, total=1)
    store.begin_run("s2")
    assert store.cancel("s2") == "cancelling"   # its coordinator (a live lease) stops it
    assert store.write_chunk("s2", [(0, "c" * 32, [1.0], {"k": 1.0}, None)]) is None  # no row after the cancel
    assert store.delete("s2") == "active"       # not purged while its owner may still write
    store.finish("s2", "done")
    assert store.get("s2")["status"] == "cancelled"
    assert store.begin_run("s2") is None  # a cancelled study is not resumed
    assert store.delete("s2") == "deleted" and store.get("s2") is None


def test_one_coordinator_per_study(tmp_path, monkeypatch):
    """A live coordinator's lease keeps others off; a crashed one's (dead pid here, or expired) does not."""
    import os
    import socket
    import subprocess
    import sys

    from service.studies import store as store_mod

    store = _store(tmp_path)
    store.create("s3", "stability", {}, total=1)
    host = socket.gethostname()
    me = f"{host}:{os.getpid()}:a"
    assert store.begin_run("s3", me) is not None
    other = f"{host}:{os.getpid()}:b"  # another runner of a live process
    assert store.active_ids(other) == [] and store.begin_run("s3", other) is None
    assert store.active_ids(me) == ["s3"] and store.renew("s3", me) and not store.renew("s3", other)

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    ghost = f"{host}:{int(dead.stdout)}:c"  # a process of this host that is gone: a crash, taken over at once
    with store.engine.begin() as conn:
        conn.execute(store_mod.studies.update().values(owner=ghost, lease_until=1e18))
    assert store.begin_run("s3", other) is not None and store.get("s3")["owner"] == other

    far = "elsewhere.example:1:d"  # another host: only an expired lease is taken over
    with store.engine.begin() as conn:
        conn.execute(store_mod.studies.update().values(owner=far, lease_until=1e18))
    assert store.begin_run("s3", me) is None
    with store.engine.begin() as conn:
        conn.execute(store_mod.studies.update().values(lease_until=0.0))
    assert store.begin_run("s3", me) is not None
    store.finish("s3", "done")
    assert store.get("s3")["owner"] is None


def test_a_cancel_of_a_study_whose_owner_is_gone_is_final_at_once(tmp_path):
    """Nobody would acknowledge it: a crashed owner's running study (or one left 'cancelling') is cancelled
    directly, by the cancel or by the next coordinator's settle_cancels, and may then be purged."""
    import socket

    store = _store(tmp_path)
    dead = f"{socket.gethostname()}:{2**22 + 12345}:dead"   # above pid_max's default: no such process
    store.create("s4", "stability", {}, total=4)
    store.begin_run("s4", dead)
    assert store.cancel("s4") == "cancelled" and store.get("s4")["owner"] is None
    assert store.delete("s4") == "deleted"
    store.create("s5", "stability", {}, total=4)
    store.begin_run("s5", dead)
    with store.engine.begin() as conn:   # as if the owner crashed after the cancel was asked
        conn.execute(sa.text("UPDATE studies SET status = 'cancelling' WHERE id = 's5'"))
    assert store.delete("s5") == "active" and store.active_ids("me") == []
    assert store.settle_cancels() == 1 and store.get("s5")["status"] == "cancelled"
    assert store.delete("s5") == "deleted" and store.delete("s5") == "missing"
