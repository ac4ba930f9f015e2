"""The study store on PostgreSQL (by URL): a throw-away server from the local PostgreSQL binaries.

Skipped when initdb/pg_ctl or the psycopg driver are not installed (tests/service/postgres_server.py);
scripts/test.sh installs both (psycopg with the test extras, the server binaries by scripts/system-deps.sh),
so CI runs it.
"""

from __future__ import annotations

import uuid

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from service.studies.blocks import encode_block
from service.studies.executors import LocalExecutor
from service.studies.runner import StudyRunner, plan_from_request
from service.studies.store import StudyStore, metadata
from tests.service import postgres_server
from tests.service.studies_helpers import small_study

pytest.importorskip("psycopg")
pytestmark = [pytest.mark.slow, pytest.mark.e2e, pytest.mark.skipif(not postgres_server.available(),
                                                   reason="PostgreSQL binaries not installed")]


@pytest.fixture(scope="module")
def pg_url():
    with postgres_server.postgres_url() as url:
        yield url


def test_postgres_store_schema_and_idempotent_writes(pg_url):
    store = StudyStore(pg_url)
    store.migrate()
    store.migrate()
    with store.engine.connect() as conn:
        assert compare_metadata(MigrationContext.configure(conn), metadata) == []
    store.create("p1", "stability", {"sweep": {}}, total=2)
    block = encode_block(0, [[1.0], [2.0]], [{"k": 0.1}, None], [None, "bad point"])
    assert store.write_chunk("p1", block) == 2
    assert store.write_chunk("p1", block) == 0
    assert (store.get("p1")["done"], store.get("p1")["failed"]) == (2, 1)
    assert store.stored_chunks("p1") == [(0, 2, block.digest)] and store.results("p1", 1, 5)[0]["error"] == "bad point"
    assert store.delete("p1") == "active"      # queued: a coordinator may still take it
    assert store.cancel("p1") == "cancelled"
    assert store.delete("p1") == "deleted" and store.get("p1") is None
    store.dispose()


def test_postgres_study_matches_sqlite(pg_url, tmp_path):
    study = small_study(3)
    out = []
    for url in (pg_url, f"sqlite:///{tmp_path / 's.db'}"):
        store = StudyStore(url)
        store.migrate()
        sid = str(uuid.uuid4())
        store.create(sid, "stability", study, plan_from_request(study).total)
        runner = StudyRunner(store, lambda: LocalExecutor(1), chunk_size=2)
        try:
            runner.run_until_idle(timeout=120)
        finally:
            runner.stop()
        assert store.get(sid)["status"] == "done"
        out.append(store.results(sid, 0, 100))
        store.dispose()
    assert out[0] == out[1] and len(out[0]) == 6  # floats survive both JSON columns exactly
