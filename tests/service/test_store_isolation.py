"""The test suite never touches the user's study store (issue 29: the user's explorer listed 6 studies they never
submitted).  tests/conftest.py points the whole session at a temporary store before any test module is imported;
these tests submit studies the way the suite's apps and servers do and find each one, by its id, in the temporary
store and not in the user's.  (The user's store is read with SQLite's immutable mode: no lock, no journal, no
write.)  The user's store, its write-ahead log and its shared-memory index (SQLite creates both when it opens a WAL
store: a -wal left beside the user's store was the trace of a server that had opened it) are fingerprinted around
each test and must be unchanged; the whole session's are compared at its end too (tests/conftest.py).  A live
server (bench/live_server.py, shared by the benchmarks and the tests) started from a user's own environment, with
no ZWIDTH_DATABASE_URL, takes a temporary store and leaves that user's store untouched."""

from __future__ import annotations

import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
from sqlalchemy.engine import make_url

import tests.conftest as suite
from bench.live_server import LiveServer
from service.settings import Settings
from tests.service.conftest import ROOT, make_client
from tests.service.studies_helpers import small_study, wait_finished


def _store_of(url: str) -> Path:
    return Path(make_url(url).database)


def _has_study(store: Path, study_id: str, immutable: bool = True) -> bool:
    """Whether the SQLite store holds the study, read without touching the file (immutable mode; not immutable:
    a store in use, whose latest writes are still in its -wal)."""
    if not store.exists():
        return False
    with sqlite3.connect(f"{store.as_uri()}?mode=ro" + ("&immutable=1" if immutable else ""), uri=True) as db:
        try:
            return db.execute("select count(*) from studies where id = ?", (study_id,)).fetchone()[0] == 1
        except sqlite3.OperationalError:        # no studies table: a store that never held a study
            return False


def _assert_not_in_the_users_store(study_id: str) -> None:
    for user_store in suite.USER_STORES:
        assert not _has_study(user_store, study_id), f"the suite's study {study_id} is in the user's {user_store}"


def _assert_only_in_the_session_store(study_id: str) -> None:
    assert _has_study(_store_of(Settings().database_url), study_id)
    _assert_not_in_the_users_store(study_id)


@pytest.fixture
def users_store_untouched():
    """The user's store(s), with their -wal and -shm files, as they were before the test (another process using
    the user's store during these few seconds would fail it: none should)."""
    before = {path: suite.fingerprint(path) for path in suite.USER_STORES}
    yield
    assert {path: suite.fingerprint(path) for path in suite.USER_STORES} == before


def test_the_fingerprint_sees_an_opening_of_a_wal_store(tmp_path):
    """What the fixture compares: a store opened by another process (its -wal and -shm present) and one written
    to differ from the store at rest."""
    store = tmp_path / "studies.db"
    with sqlite3.connect(store) as db:
        db.execute("pragma journal_mode=wal")
        db.execute("create table t (x)")
    db.close()
    rest = suite.fingerprint(store)
    assert rest is not None and [p[0] for p in rest] == ["studies.db"]
    reader = sqlite3.connect(store)
    reader.execute("select count(*) from t").fetchone()
    try:
        assert [p[0] for p in suite.fingerprint(store)] == ["studies.db", "studies.db-wal", "studies.db-shm"]
    finally:
        reader.close()
    assert suite.fingerprint(store) == rest


def test_the_session_store_is_temporary_and_not_the_users():
    assert suite.SESSION_STORE_DIR is not None and suite.USER_STORES
    store = _store_of(Settings().database_url)
    assert store.is_relative_to(suite.SESSION_STORE_DIR) and store not in suite.USER_STORES
    if sys.platform == "linux":   # platformdirs' default, what a server without ZWIDTH_DATABASE_URL uses
        env = {k: v for k, v in os.environ.items() if k != "ZWIDTH_DATABASE_URL"}
        assert all(p.is_relative_to(suite.SESSION_STORE_DIR) for p in suite.user_stores(env))


def test_a_study_through_the_test_client_lands_in_the_temporary_store(users_store_untouched, monkeypatch):
    monkeypatch.setenv("ZWIDTH_STUDY_WORKERS", "1")     # one pool worker is enough to find the study by its id
    with make_client() as client:
        r = client.post("/v1/studies", json=small_study(2))
        assert r.status_code == 202, r.text
        study_id = r.json()["id"]
        wait_finished(lambda i: client.get(f"/v1/studies/{i}").json(), study_id)
    _assert_only_in_the_session_store(study_id)


@pytest.mark.slow
def test_a_server_process_and_the_cli_use_the_temporary_store(tmp_path, users_store_untouched):
    code = "from service.settings import Settings; print(Settings().database_url)"
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert _store_of(out.stdout.strip()).is_relative_to(suite.SESSION_STORE_DIR)
    server = LiveServer({"ZWIDTH_STUDY_WORKERS": "1"}, timeout=60.0)   # as the suite's fixtures start one (1 pool worker)
    try:
        assert server.database_url is not None and server.database_url != Settings().database_url
        r = httpx.post(server.url + "/v1/studies", json=small_study(2), timeout=30)
        assert r.status_code == 202, r.text
        study_id = r.json()["id"]
        wait_finished(lambda i: httpx.get(f"{server.url}/v1/studies/{i}", timeout=30).json(), study_id)
        assert _has_study(_store_of(server.database_url), study_id, immutable=False)
    finally:
        server.stop()
    assert not _store_of(server.database_url).parent.exists()    # the server's temporary store is gone with it
    _assert_not_in_the_users_store(study_id)


@pytest.mark.slow
def test_a_live_server_from_a_users_environment_leaves_the_users_store_untouched(tmp_path, monkeypatch):
    """Reproducer: a benchmark's server (bench/live_server.py) started from the user's shell, with no
    ZWIDTH_DATABASE_URL, migrated and used the user's store; killed, it left studies.db-wal beside it."""
    home = tmp_path / "home"
    store = home / ".local" / "share" / "zwidth" / "studies.db"
    store.parent.mkdir(parents=True)
    with sqlite3.connect(store) as db:     # the user's existing store, at rest (WAL, as the service keeps it)
        db.execute("pragma journal_mode=wal")
        db.execute("create table mine (x)")
    db.close()
    before = suite.fingerprint(store)
    monkeypatch.delenv("ZWIDTH_DATABASE_URL")          # the user's shell: no store named, the default one
    server = LiveServer({"HOME": str(home), "XDG_DATA_HOME": None, "ZWIDTH_PRESTART_WORKERS": "false",
                         "ZWIDTH_STUDY_WORKERS": "1"}, timeout=60.0)
    try:
        r = httpx.post(server.url + "/v1/studies", json=small_study(2), timeout=30)
        assert r.status_code == 202, r.text
        wait_finished(lambda i: httpx.get(f"{server.url}/v1/studies/{i}", timeout=30).json(), r.json()["id"])
        assert suite.fingerprint(store) == before      # while it runs: not opened (no -wal, no -shm)
        server.kill()                                  # as a crash would: nothing is closed
    finally:
        server.stop()
    assert suite.fingerprint(store) == before
    assert sorted(p.name for p in store.parent.iterdir()) == ["studies.db"]
