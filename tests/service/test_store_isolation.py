"""The test suite never touches the user's study store (issue 29: the user's explorer listed 6 studies they never
submitted).  tests/conftest.py points the whole session at a temporary store before any test module is imported;
these tests submit studies the way the suite's apps and servers do and find each one, by its id, in the temporary
store and not in the user's.  (The user's store is read with SQLite's immutable mode: no lock, no journal, no
write.  Its modification time alone proves nothing on a machine where another process may use it; it is
compared at the end of the session and reported.)"""

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


def _has_study(store: Path, study_id: str) -> bool:
    """Whether the SQLite store holds the study, read without touching the file (immutable mode)."""
    if not store.exists():
        return False
    with sqlite3.connect(f"{store.as_uri()}?mode=ro&immutable=1", uri=True) as db:
        try:
            return db.execute("select count(*) from studies where id = ?", (study_id,)).fetchone()[0] == 1
        except sqlite3.OperationalError:        # no studies table: a store that never held a study
            return False


def _assert_only_in_the_session_store(study_id: str) -> None:
    assert _has_study(_store_of(Settings().database_url), study_id)
    for user_store in suite.USER_STORES:
        assert not _has_study(user_store, study_id), f"the suite's study {study_id} is in the user's {user_store}"


def test_the_session_store_is_temporary_and_not_the_users():
    assert suite.SESSION_STORE_DIR is not None and suite.USER_STORES
    store = _store_of(Settings().database_url)
    assert store.is_relative_to(suite.SESSION_STORE_DIR) and store not in suite.USER_STORES
    if sys.platform == "linux":   # platformdirs' default, what a server without ZWIDTH_DATABASE_URL uses
        env = {k: v for k, v in os.environ.items() if k != "ZWIDTH_DATABASE_URL"}
        assert all(p.is_relative_to(suite.SESSION_STORE_DIR) for p in suite.user_stores(env))


def test_a_study_through_the_test_client_lands_in_the_temporary_store():
    with make_client() as client:
        r = client.post("/v1/studies", json=small_study(2))
        assert r.status_code == 202, r.text
        study_id = r.json()["id"]
        wait_finished(lambda i: client.get(f"/v1/studies/{i}").json(), study_id)
    _assert_only_in_the_session_store(study_id)


@pytest.mark.slow
def test_a_server_process_and_the_cli_use_the_temporary_store(tmp_path):
    code = "from service.settings import Settings; print(Settings().database_url)"
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert _store_of(out.stdout.strip()).is_relative_to(suite.SESSION_STORE_DIR)
    server = LiveServer(timeout=60.0)         # as the suite's live-server fixtures start one
    try:
        r = httpx.post(server.url + "/v1/studies", json=small_study(2), timeout=30)
        assert r.status_code == 202, r.text
        study_id = r.json()["id"]
        wait_finished(lambda i: httpx.get(f"{server.url}/v1/studies/{i}", timeout=30).json(), study_id)
    finally:
        server.stop()
    _assert_only_in_the_session_store(study_id)
