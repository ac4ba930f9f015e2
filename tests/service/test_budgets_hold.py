"""Issue 28's budgets that slipped, each reproduced first: a locked SQLite store held POST /v1/studies 30 s (its busy
timeout) before the 503; nothing capped the studies queued; a budget overrun was answered only after the worker's
kill and re-fork (a 10 s budget answered at 13.8 s under CPU contention); the inline cost model took an
undamped-cable analysis for 11 ms when it cost 80 ms."""

from __future__ import annotations

import sqlite3
import threading
import time

import pytest

from models.device import Device
from models.velocity_filter import MovingAverage, rendering
from optim.stability.analysis import analyse_stability
from service.cost import filter_cost_ms, rendered_cost_ms, stability_cost_ms
from service.executor import BoundedExecutor, ComputeTimeout

from .conftest import LHIFAM_RIGID, make_client

STUDY = {"problem": "stability", "base": {"device": LHIFAM_RIGID, "requirements": {"stiffness": 2000}},
         "sweep": {"device.delay": [0.0, 0.001]}}


@pytest.mark.serial   # a wall-clock budget: alone under pytest-xdist (tests/conftest.py)
def test_a_locked_store_answers_503_within_the_request_budget(tmp_path):
    """The busy wait is min(ZWIDTH_STUDY_BUSY_TIMEOUT, ZWIDTH_REQUEST_TIMEOUT): here the 2 s budget binds."""
    db = tmp_path / "s.db"
    with make_client(database_url=f"sqlite:///{db}", request_timeout=2.0) as c:
        assert c.post("/v1/studies", json=STUDY).status_code == 202
        c.app.state.study_runner.stop()          # its coordinator must not be the one waiting
        lock = sqlite3.connect(db, timeout=1)
        lock.execute("BEGIN EXCLUSIVE")
        try:
            t0 = time.monotonic()
            r = c.post("/v1/studies", json=STUDY)
            took = time.monotonic() - t0
        finally:
            lock.rollback()
            lock.close()
    assert r.status_code == 503 and "retry-after" in r.headers, r.text
    assert 1.5 < took < 4.0, took                   # was 30 s


def test_studies_past_the_active_cap_are_429_with_retry_after(tmp_path, monkeypatch):
    monkeypatch.setenv("ZWIDTH_STUDY_MAX_ACTIVE", "2")
    with make_client(database_url=f"sqlite:///{tmp_path / 's.db'}") as c:
        c.app.state.study_runner.stop()          # nothing runs: every study stays queued
        assert [c.post("/v1/studies", json=STUDY).status_code for _ in range(2)] == [202, 202]
        r = c.post("/v1/studies", json=STUDY)
        assert r.status_code == 429 and int(r.headers["retry-after"]) > 0, r.text
        assert "ZWIDTH_STUDY_MAX_ACTIVE" in r.json()["detail"]
        ids = [s["id"] for s in c.get("/v1/studies").json()["studies"]]
        assert len(ids) == 2
        assert c.delete(f"/v1/studies/{ids[0]}").status_code == 200
        assert c.post("/v1/studies", json=STUDY).status_code == 202     # a place is free again


@pytest.mark.serial   # a wall-clock budget: alone under pytest-xdist (tests/conftest.py)
@pytest.mark.slow
def test_the_503_is_answered_before_the_worker_is_replaced():
    """The re-fork of a replacement worker is slowed to 3 s (CPU contention): the caller still has its 503 at the
    budget, not after the re-fork (time.sleep itself is the call: nothing to import in the worker)."""
    ex = BoundedExecutor(workers=1, timeout=1.0, max_queue=2)
    try:
        ex.warm_up()
        assert ex.run(time.sleep, 0.0) is None          # a worker is up
        start = ex._start

        def slow_start(slot):
            time.sleep(3.0)
            return start(slot)

        ex._start = slow_start
        t0 = time.monotonic()
        with pytest.raises(ComputeTimeout):
            ex.run(time.sleep, 30.0)
        assert time.monotonic() - t0 < 2.0
    finally:
        ex.shutdown()


@pytest.mark.parametrize("delay_samples", [0, 20, 50, 150])
@pytest.mark.parametrize("damping", [0.0, 5.0])
def test_the_inline_cost_model_holds_for_undamped_cables(delay_samples, damping):
    """Undamped-cable analyses were estimated at 11 ms and took 80 ms (inline, unbounded).  Measured (the best of
    3) within 3× the estimate, in CPU time of this process: the estimate models compute, and wall time on the
    shared 2-core machine (another xdist worker, other jobs) was 3.3× the CPU time at load 9.5 (140 ms wall,
    43 ms CPU against the 47 ms estimate, 2026-12-03).  A slower analysis still fails it: CPU time counts every
    thread of the process, so it can only over-count."""
    base = Device(preset="lhifam")
    cable = {**base.cable.model_dump(), "damping": 0.0, "body_damping": 0.0}
    dev = Device(cable=cable, sample_time=0.001, delay=delay_samples * 0.001)
    analyse_stability(dev, 1000.0, damping)        # compiled kernels warm
    best = float("inf")
    for _ in range(3):
        t0 = time.process_time()
        analyse_stability(dev, 1000.0, damping)
        best = min(best, (time.process_time() - t0) * 1e3)
    est = stability_cost_ms(dev, "exact", damping, 1000)
    assert best <= 3.0 * est, (best, est)


#: A wall rendered with the longest moving average a request may ask (1000 samples): one exact analysis of the
#: rigid LHIFAM costs ≈ 2.3 s of CPU (2026-12-04); it was estimated at 1 ms (today's wall × 10) and ran on the
#: event loop, 4.5–7.8 s past a 1 s budget, every other request waiting.
LONG_AVERAGE = {"device": LHIFAM_RIGID, "controller": {"stiffness": 1000, "damping": 5, "velocity_filter": {
    "kind": "moving_average", "samples": 1000}}}


def test_the_rendered_cost_grows_with_the_filter_order():
    """The estimate sends a long average to a worker (over the inline threshold) and keeps today's wall and a short
    filter's estimate where they were; measured costs in filter_cost_ms's docstring (within ≈ 2× of 0.5 n +
    2.5e-3 n² ms, n the filter's order)."""
    dev = Device(**LHIFAM_RIGID)
    base = stability_cost_ms(dev, "exact", 5.0, 1000)
    long = rendering(MovingAverage(kind="moving_average", samples=1000), 0.0, dev.sample_time)
    short = rendering(MovingAverage(kind="moving_average", samples=2), 0.0, dev.sample_time)
    inline = BoundedExecutor(workers=1).inline_cost_ms
    assert rendered_cost_ms(base, None) == base
    assert rendered_cost_ms(base, long) > 1000.0 > inline            # ≈ 3 s
    assert rendered_cost_ms(base, short) < inline                    # two samples: still inline (≈ 2 ms)
    assert filter_cost_ms(long) == pytest.approx(0.5 * 999 + 2.5e-3 * 999 ** 2)
    assert rendered_cost_ms(base, long, calls=45) == pytest.approx(10 * base + 45 * filter_cost_ms(long))


@pytest.mark.serial   # a wall-clock budget: alone under pytest-xdist (tests/conftest.py)
def test_a_long_moving_average_answers_within_the_budget_and_leaves_the_loop_free():
    """The analysis goes to a worker: the request answers 503 at its 1 s budget (or 200 within it, on a fast
    machine) and, while it runs, /healthz answers at once (the event loop is free)."""
    with make_client(request_timeout=1.0, compute_workers=1, access_log=False) as c:
        executor = c.app.state.executor
        executor.warm_up()                     # the forkserver's first start is not part of the request
        replaced = executor.replaced
        out = {}

        def long_request():
            t0 = time.monotonic()
            out["r"] = c.post("/v1/analysis/stability", json=LONG_AVERAGE)
            out["took"] = time.monotonic() - t0

        worker = threading.Thread(target=long_request)
        worker.start()
        time.sleep(0.3)                        # the long request is being computed
        t0 = time.monotonic()
        health = c.get("/healthz")
        health_took = time.monotonic() - t0
        worker.join(30.0)
    r = out["r"]
    assert health.status_code == 200 and health_took < 0.5, health_took      # was blocked for seconds
    assert out["took"] < 3.0, out["took"]                                    # was 4.5–7.8 s
    if r.status_code == 503:
        assert "within the request time budget of 1 s" in r.json()["detail"], r.text
        assert executor.replaced == replaced + 1
    else:
        assert r.status_code == 200 and out["took"] < 1.5, (r.status_code, r.text[:300])
