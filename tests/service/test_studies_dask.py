"""A study through a real Dask cluster (scheduler + two single-thread workers on loopback) gives
the same numbers, bit for bit, as the local process pool."""

from __future__ import annotations

import uuid

import pytest

from bench.dask_cluster import local_dask_cluster
from service.studies.executors import DaskExecutor, LocalExecutor
from service.studies.runner import StudyRunner, plan_from_request
from service.studies.store import StudyStore

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

STUDY = {"problem": "stability",
         "base": {"device": {"preset": "lhifam", "delay": 0.0005}, "requirements": {"stiffness": 3000.0}},
         "sweep": {"device.cable.stiffness": {"start": 2e4, "stop": 2e5, "num": 6, "scale": "log"},
                   "requirements.damping": [0.0, 4.0]}}


def _run(db, executor_factory) -> tuple[dict, list[dict]]:
    store = StudyStore(f"sqlite:///{db}")
    store.migrate()
    sid = str(uuid.uuid4())
    store.create(sid, "stability", STUDY, plan_from_request(STUDY).total)
    runner = StudyRunner(store, executor_factory, chunk_size=2)
    try:
        runner.run_until_idle(timeout=120)
    finally:
        runner.stop()
    row, results = store.get(sid), store.results(sid, 0, 1000)
    store.dispose()
    return row, results


def test_dask_matches_local(tmp_path):
    with local_dask_cluster(workers=2) as address:
        executor = DaskExecutor(address)
        assert executor.slots == 2
        row, dask_rows = _run(tmp_path / "dask.db", lambda: executor)
    assert row["status"] == "done" and row["done"] == row["total"] == 12 and row["failed"] == 0
    row, local_rows = _run(tmp_path / "local.db", lambda: LocalExecutor(1))
    assert row["status"] == "done"
    assert [r["idx"] for r in dask_rows] == list(range(12))
    assert dask_rows == local_rows
    # the cable mode is in play: results carry the rigid model's K_cr beside the cable one
    assert all(r["result"]["rigid_critical_stiffness"] is not None for r in dask_rows)
