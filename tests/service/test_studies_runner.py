"""The coordinator survives a worker killed by the OS, and never completes a study it could not compute."""

from __future__ import annotations

import concurrent.futures as cf
import os
import signal
import threading
import time
import uuid

from service.studies.executors import LocalExecutor
from service.studies.runner import StudyRunner, plan_from_request
from service.studies.store import StudyStore
from tests.service.studies_helpers import small_study


def _store_with(tmp_path, study) -> tuple[StudyStore, str]:
    store = StudyStore(f"sqlite:///{tmp_path / 's.db'}")
    store.migrate()
    sid = str(uuid.uuid4())
    store.create(sid, study["problem"], study, plan_from_request(study).total)
    return store, sid


def test_a_killed_pool_worker_is_replaced(tmp_path):
    study = small_study(num_delay=100)
    store, sid = _store_with(tmp_path, study)
    executor = LocalExecutor(2)
    runner = StudyRunner(store, lambda: executor, chunk_size=4)
    killed = []

    def kill_one_worker():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            pool = executor._pool
            if pool is not None and pool._processes and (store.get(sid)["done"] >= 20):
                pid = next(iter(pool._processes))
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.01)
    t = threading.Thread(target=kill_one_worker)
    t.start()
    try:
        runner.run_until_idle(timeout=120)
    finally:
        t.join()
        runner.stop()
    row = store.get(sid)
    assert killed and row["status"] == "done" and row["done"] == row["total"] == 200 and row["failed"] == 0
    assert [r["idx"] for r in store.iter_results(sid)] == list(range(200))


class _Failing:
    """An executor whose every task raises (a lost cluster, a worker that cannot import)."""

    kind, slots = "failing", 1

    def __init__(self):
        self.pool = cf.ThreadPoolExecutor(1)
        self.calls = 0

    def submit(self, fn, *args):
        self.calls += 1
        return self.pool.submit(lambda: (_ for _ in ()).throw(RuntimeError("worker lost")))

    def wait(self, futures, timeout):
        done, pending = cf.wait(futures, timeout=timeout, return_when=cf.FIRST_COMPLETED)
        return set(done), set(pending)

    def cancel(self, futures):
        for f in futures:
            f.cancel()

    def reset(self):
        pass

    def close(self):
        self.pool.shutdown()


def test_a_chunk_that_keeps_failing_fails_the_study(tmp_path):
    store, sid = _store_with(tmp_path, small_study(2))
    executor = _Failing()
    runner = StudyRunner(store, lambda: executor, chunk_size=4)
    runner.run_until_idle(timeout=30)
    runner.stop()
    row = store.get(sid)
    assert row["status"] == "failed" and "worker lost" in row["error"] and row["done"] == 0
    assert executor.calls >= 3  # retried before giving up


def test_an_unreachable_executor_leaves_the_study_active_with_the_reason(tmp_path):
    store, sid = _store_with(tmp_path, small_study(2))

    def no_cluster():
        raise OSError("Timed out trying to connect to tcp://10.0.0.1:8786")
    runner = StudyRunner(store, no_cluster, chunk_size=4, poll=0.05)
    runner.start()
    try:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not store.get(sid)["error"]:
            time.sleep(0.05)
    finally:
        runner.stop()
    row = store.get(sid)
    assert row["status"] == "running" and "Timed out trying to connect" in row["error"]
    assert row["done"] == 0
