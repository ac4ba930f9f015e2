"""The study store: Alembic schema equals the code's tables, WAL, idempotent chunk writes, paging over blocks."""

from __future__ import annotations

import sqlalchemy as sa
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from service.studies.blocks import encode_block
from service.studies.store import StudyStore, metadata


def _block(start: int, rows: list[tuple]):
    """The block of rows (values, result, error) of points start, start + 1, …"""
    return encode_block(start, [v for v, _, _ in rows], [r for _, r, _ in rows], [e for _, _, e in rows])


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
        assert conn.execute(sa.text("SELECT version_num FROM alembic_version")).scalar() == "0003"


def test_chunks_are_written_once(tmp_path):
    store = _store(tmp_path)
    store.create("s1", "stability", {"sweep": {}}, total=3)
    block = _block(0, [([1.0], {"k": 1.0}, None), ([2.0], None, "bad point")])
    assert store.write_chunk("s1", block) == 2
    assert store.write_chunk("s1", block) == 0  # a chunk Dask ran twice changes nothing
    row = store.get("s1")
    assert (row["done"], row["failed"]) == (2, 1)
    assert store.stored_chunks("s1") == [(0, 2, block.digest)]
    assert [r["idx"] for r in store.iter_results("s1", batch=1)] == [0, 1]
    # a restart recounts from the chunks themselves
    assert store.begin_run("s1")["done"] == 2 and store.get("s1")["status"] == "running"


def test_cancel_wins_over_finish(tmp_path):
    store = _store(tmp_path)
    store.create("s2", "stability", {}, total=1)
    store.begin_run("s2")
    assert store.cancel("s2") == "cancelling"   # its coordinator (a live lease) stops it
    assert store.write_chunk("s2", _block(0, [([1.0], {"k": 1.0}, None)])) is None  # no row after the cancel
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


def test_pages_count_stored_points_across_chunks(tmp_path):
    """offset/limit count stored points in point order, as rows of a table would, whatever the chunks and gaps."""
    store = _store(tmp_path)
    store.create("s6", "stability", {}, total=40)
    pieces = [(0, 3), (3, 1), (10, 7), (20, 5)]          # points 4 … 9 and 17 … 19 not stored (yet)
    for start, n in reversed(pieces):
        store.write_chunk("s6", _block(start, [([float(i)], {"i": i}, None) for i in range(start, start + n)]))
    stored = [i for a, n in pieces for i in range(a, a + n)]
    for offset in range(0, 18):
        for limit in (1, 2, 5, 16, 100):
            page = store.results("s6", offset, limit)
            assert [r["idx"] for r in page] == stored[offset:offset + limit]
            assert all(r["params"] == [float(r["idx"])] and r["result"] == {"i": r["idx"]} for r in page)
    assert [r["idx"] for r in store.iter_results("s6", batch=2)] == stored
    assert store.get("s6")["done"] == 16
    # a stale chunk is dropped and the counts follow
    assert store.drop_chunks("s6", [10]) == 1 and store.get("s6")["done"] == 9


def test_an_old_store_is_migrated_with_every_point(tmp_path):
    """A store of revision 0002 (one JSON row per point) opens: its points become blocks holding the same values."""
    import json

    from alembic import command
    from alembic.config import Config

    from service.studies.store import _MIGRATIONS

    store = StudyStore(f"sqlite:///{tmp_path / 'old.db'}")
    cfg = Config()
    cfg.set_main_option("script_location", str(_MIGRATIONS))
    with store.engine.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "0002")
    rows = [(0, [1.0, 2.0], {"k": 1.5, "s": "x", "b": True, "n": None}, None),
            (1, [0.1, 3.0], None, "invalid device: mass must be > 0"),
            (2, [1e-300, -0.0], {"k": 2.0000000000000004, "i": 3}, None),
            (5, [4.0, 5.0], {"k": float("inf")}, None)]            # 3 and 4 were never stored
    with store.engine.begin() as conn:
        conn.execute(sa.text("INSERT INTO studies (id, problem, request, status, total, done, failed, created_at, "
                             "run_start_done) VALUES ('old', 'stability', '{}', 'running', 6, 4, 1, 0, 0)"))
        for i, (idx, params, result, error) in enumerate(rows):
            conn.execute(sa.text("INSERT INTO study_results VALUES ('old', :h, :i, :p, :r, :e)"),
                         dict(h=f"{i:032d}", i=idx, p=json.dumps(params), r=json.dumps(result), e=error))
    store.migrate()
    got = list(store.iter_results("old"))
    assert [(r["idx"], r["params"], r["result"], r["error"]) for r in got] == rows
    assert [(a, n) for a, n, _ in store.stored_chunks("old")] == [(0, 3), (5, 1)]
    assert store.begin_run("old")["done"] == 4 and store.get("old")["failed"] == 1
    with store.engine.connect() as conn:
        assert not sa.inspect(conn).has_table("study_results")
