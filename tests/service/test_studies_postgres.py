"""The study store on PostgreSQL (by URL): a throw-away server from the local PostgreSQL binaries.

Skipped when initdb/pg_ctl or the psycopg driver are not installed; scripts/test.sh installs both
(psycopg with the test extras, the server binaries by scripts/system-deps.sh), so CI runs it.  PostgreSQL
refuses to run as root, so as root the server runs as ``nobody``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import uuid
from pathlib import Path

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from service.studies.executors import LocalExecutor
from service.studies.runner import StudyRunner, plan_from_request
from service.studies.store import StudyStore, metadata
from tests.service.studies_helpers import small_study

pytest.importorskip("psycopg")
def _binary(name: str) -> str | None:
    """On PATH, else Debian's versioned directory (the postgresql package does not put initdb on PATH)."""
    found = shutil.which(name)
    if found:
        return found
    candidates = sorted(Path("/usr/lib/postgresql").glob(f"*/bin/{name}"), key=lambda p: int(p.parts[-3]))
    return str(candidates[-1]) if candidates else None


INITDB, PG_CTL = _binary("initdb"), _binary("pg_ctl")
pytestmark = [pytest.mark.e2e, pytest.mark.skipif(not (INITDB and PG_CTL), reason="PostgreSQL binaries not installed")]


def _as_server_user(cmd: list[str]) -> list[str]:
    return ["runuser", "-u", "nobody", "--", *cmd] if os.geteuid() == 0 else cmd


@pytest.fixture(scope="module")
def pg_url():
    import socket

    root = Path(tempfile.mkdtemp(prefix="zwidth-pg-"))
    if os.geteuid() == 0:
        shutil.chown(root, "nobody")
    data = root / "data"
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    subprocess.run(_as_server_user([INITDB, "-D", str(data), "-U", "zwidth", "--auth=trust", "-E", "UTF8"]),
                   check=True, capture_output=True, timeout=120)
    subprocess.run(_as_server_user([PG_CTL, "-D", str(data), "-l", str(root / "log"), "-w", "start", "-o",
                                    f"-p {port} -k {root} -c listen_addresses=''"]),
                   check=True, capture_output=True, timeout=60)
    try:
        yield f"postgresql+psycopg://zwidth@/postgres?host={root}&port={port}"
    finally:
        subprocess.run(_as_server_user([PG_CTL, "-D", str(data), "-m", "immediate", "stop"]), capture_output=True,
                       timeout=60)
        shutil.rmtree(root, ignore_errors=True)


def test_postgres_store_schema_and_idempotent_writes(pg_url):
    store = StudyStore(pg_url)
    store.migrate()
    store.migrate()
    with store.engine.connect() as conn:
        assert compare_metadata(MigrationContext.configure(conn), metadata) == []
    store.create("p1", "stability", {"sweep": {}}, total=2)
    rows = [(0, "a" * 32, [1.0], {"k": 0.1}, None), (1, "b" * 32, [2.0], None, "bad point")]
    assert store.write_chunk("p1", rows) == 2
    assert store.write_chunk("p1", rows) == 0
    assert (store.get("p1")["done"], store.get("p1")["failed"]) == (2, 1)
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
