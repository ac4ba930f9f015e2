"""A study survives a SIGKILL of the server: restarted, it resumes and every point is stored once.

The server runs as a real process (uvicorn on a free loopback port, temp SQLite store via
ZWIDTH_DATABASE_URL).  The whole process group is killed with SIGKILL (server and its pool
workers, as a crash would), then a new server resumes from the store alone.
"""

from __future__ import annotations

import time
from pathlib import Path

import httpx
import pytest

from bench.live_server import LiveServer
from tests.service.studies_helpers import small_study, wait_finished

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


class Server(LiveServer):
    """The study service on a free port, on the store ``db``, its output appended to ``log`` (kept across restarts)."""

    def __init__(self, db: Path, log: Path):
        super().__init__({"ZWIDTH_DATABASE_URL": f"sqlite:///{db}", "ZWIDTH_STUDY_WORKERS": "2",
                          "ZWIDTH_STUDY_CHUNK_SIZE": "8", "ZWIDTH_DASK_SCHEDULER": None},
                         log=log, ready_path="/v1/studies")
        self.http = httpx.Client(base_url=self.url, timeout=30)

    def get(self, sid: str) -> dict:
        return self.http.get(f"/v1/studies/{sid}").json()

    def rows(self, sid: str) -> list[dict]:
        rows, offset = [], 0
        while offset is not None:
            page = self.http.get(f"/v1/studies/{sid}/results", params={"offset": offset, "limit": 500}).json()
            rows += page["rows"]
            offset = page["next_offset"]
        return rows

    def kill(self) -> None:
        self.http.close()
        super().kill()

    def stop(self) -> None:
        self.http.close()
        super().stop()


def test_sigkill_mid_run_then_resume(tmp_path):
    db, log = tmp_path / "store.db", tmp_path / "server.log"
    study = small_study(num_delay=2000)  # 4000 points: ~1 s of the vectorised problem on 2 workers
    server = Server(db, log)
    try:
        sid = server.http.post("/v1/studies", json=study).json()["id"]
        queued = server.http.post("/v1/studies", json=small_study(num_delay=3)).json()["id"]
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            st = server.get(sid)
            if st["done"] >= 40:
                break
            time.sleep(0.02)
        server.kill()  # mid-run: the study is partly stored, the second one only queued
    finally:
        server.kill()
    assert 40 <= st["done"] < st["total"] == 4000, st

    server = Server(db, log)
    try:
        st = wait_finished(server.get, sid, timeout=90)
        assert st["status"] == "done" and st["done"] == 4000 and st["failed"] == 0, st
        assert st["resumed_from"] >= 40  # what was stored before the kill was not recomputed
        resumed = server.rows(sid)
        assert wait_finished(server.get, queued, timeout=60)["status"] == "done"  # stored before its 202
        fresh = server.http.post("/v1/studies", json=study).json()["id"]
        assert wait_finished(server.get, fresh, timeout=90)["resumed_from"] == 0
        uninterrupted = server.rows(fresh)
    finally:
        server.stop()
    assert [r["index"] for r in resumed] == list(range(4000))  # every point, exactly once
    # identical numbers, bit for bit (the resumed points ran in other chunks than in the fresh run)
    assert resumed == uninterrupted


@pytest.mark.slow
def test_sigkill_of_the_server_alone_leaves_no_process_and_resumes_once(tmp_path):
    """Issue 18: ``kill -9 <server pid>`` (not its group) used to leave the resource tracker and the pools'
    workers alive with parent 1 (~240 MB per crash).  Now nothing of the server's session outlives it by 5 s,
    and the next server resumes the study: every point stored exactly once."""
    db, log = tmp_path / "store.db", tmp_path / "server.log"
    study = small_study(num_delay=5000)  # 10 000 points: still running when killed
    server = Server(db, log)
    try:
        deadline = time.monotonic() + 90
        while server.http.get("/readyz").status_code != 200 and time.monotonic() < deadline:
            time.sleep(0.1)   # the compute workers (and their forkserver) are up
        sid = server.http.post("/v1/studies", json=study).json()["id"]
        while server.get(sid)["done"] < 40 and time.monotonic() < deadline:
            time.sleep(0.02)  # the study pool's workers are up
        before = server.session_pids()
        assert len(before) >= 1 + 2 + 2, before   # server, compute forkserver + workers, study workers, trackers
        server.crash()
        deadline = time.monotonic() + 5.0
        while server.session_pids() and time.monotonic() < deadline:
            time.sleep(0.1)
        left = server.session_pids()
    finally:
        server.kill()   # whatever is left (the assertion below says if anything was)
    assert left == [], f"alive 5 s after the server's SIGKILL: {left} of {before}"

    server = Server(db, log)
    try:
        st = wait_finished(server.get, sid, timeout=120)
        assert st["status"] == "done" and st["done"] == st["total"] == 10000 and st["resumed_from"] >= 40, st
        page = server.http.get(f"/v1/studies/{sid}/results", params={"offset": 0, "limit": 10000}).json()
        assert [r["index"] for r in page["rows"]] == list(range(10000))
    finally:
        server.stop()
    import sqlite3

    with sqlite3.connect(db) as conn:   # exactly once: the stored chunks tile the points, none overlaps another
        spans = conn.execute("SELECT start, n FROM study_chunks WHERE study_id = ? ORDER BY start", (sid,)).fetchall()
    assert spans[0][0] == 0 and all(a + n == b for (a, n), (b, _) in zip(spans, spans[1:]))
    assert sum(n for _, n in spans) == 10000
