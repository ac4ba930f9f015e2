"""The coordinator survives a worker killed by the OS, and never completes a study it could not compute."""

from __future__ import annotations

import concurrent.futures as cf
import os
import signal
import threading
import time
import uuid

import pytest

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


@pytest.mark.slow
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
    # the exception's type is said, its text (internal names, paths) stays in the log
    assert row["status"] == "failed" and row["done"] == 0
    assert "failed 3 times" in row["error"] and "worker lost" not in row["error"] and "server log" in row["error"]
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
    # the reason's type is said; the scheduler's address stays in the server log
    assert row["status"] == "running" and "OSError" in row["error"] and "10.0.0.1" not in row["error"]
    assert row["done"] == 0


class _Paced:
    """Threads that evaluate the real chunk, taking ``seconds`` per point (a slow problem, made deterministic)."""

    kind, slots = "paced", 2

    def __init__(self, seconds: float):
        self.pool = cf.ThreadPoolExecutor(self.slots)
        self.seconds = seconds
        self.sizes: list[int] = []

    def submit(self, fn, *args):
        self.sizes.append(len(args[-2]))   # (…, start, values, hash)

        def run():   # a slow evaluation: the block says how long it took, as a worker's does
            time.sleep(self.seconds * len(args[-2]))
            out = fn(*args)
            return out._replace(seconds=out.seconds + self.seconds * len(args[-2]))
        return self.pool.submit(run)

    wait, cancel, reset = _Failing.wait, _Failing.cancel, _Failing.reset

    def close(self):
        self.pool.shutdown()


@pytest.mark.slow
def test_progress_moves_per_point_not_per_chunk(tmp_path):
    """16 points of 0.1 s each with chunks of up to 64: `done` takes intermediate values as results arrive
    (it used to sit at 0 and jump to 16), and no chunk takes much longer than CHUNK_SECONDS."""
    from service.studies.runner import CHUNK_SECONDS

    store, sid = _store_with(tmp_path, small_study(8))        # 8 delays × 2 dampings = 16 points
    executor = _Paced(0.1)
    runner = StudyRunner(store, lambda: executor, chunk_size=64, poll=0.05)
    seen = []
    runner.start()
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            row = store.get(sid)
            seen.append(row["done"])
            if row["status"] == "done":
                break
            time.sleep(0.02)
    finally:
        runner.stop()
        executor.close()
    row = store.get(sid)
    assert row["status"] == "done" and row["done"] == row["total"] == 16
    intermediate = sorted(set(v for v in seen if 0 < v < 16))
    assert len(intermediate) >= 4, (intermediate, executor.sizes)
    assert seen == sorted(seen)                                 # never goes back
    assert executor.sizes[0] == 1 and max(executor.sizes) * 0.1 <= 2 * CHUNK_SECONDS, executor.sizes
    assert [r["idx"] for r in store.iter_results(sid)] == list(range(16))


def test_adaptive_chunk_size():
    runner = StudyRunner(None, lambda: None, chunk_size=64)
    assert runner.adaptive_size(64, None, 1000, 4) == 1          # unknown pace: one point
    assert runner.adaptive_size(64, 0.1, 1000, 4) == 5           # 0.5 s of 0.1 s points
    assert runner.adaptive_size(64, 1e-5, 1000, 4) == 64         # fast points: the configured chunk
    assert runner.adaptive_size(64, 0.01, 12, 4) == 3            # the last slow points spread over the workers
    assert runner.adaptive_size(64, 1e-5, 12, 4) >= 12           # ... but 0.1 ms of work stays one chunk
    assert runner.adaptive_size(64, 1e-5, 200, 4) == 64          # (MIN_CHUNK_SECONDS: 2,000 points of 10 µs)
    assert runner.adaptive_size(10**6, 1e-5, 10**5, 4) == 25000  # an even share while it is worth a task
    assert runner.adaptive_size(64, 10.0, 1000, 4) == 1


def test_chunk_ends_align_to_the_grids_first_axis_blocks():
    """Issue 32: a chunk ends on a multiple of the points sharing the first axis's value (a damped cable's delays are
    then never split over two chunks that each factor the cable) when that keeps it within half and twice its size."""
    from service.studies.runner import aligned_stop, grid_stride

    assert aligned_stop(1050, 2050, 10**6, 1050, 16384) == 2100      # a chunk under load: one block, not 2 halves
    assert aligned_stop(1, 1061, 10**6, 1050, 16384) == 1050         # after the first 1-point chunk
    assert aligned_stop(37000, 53384, 10**6, 1050, 16384) == 52500   # down: up would pass the largest chunk
    assert aligned_stop(0, 1, 10**6, 1050, 16384) == 1               # the 1-point chunk stays one point
    assert aligned_stop(0, 300, 10**6, 1050, 16384) == 300           # far from a multiple: as planned
    assert aligned_stop(2000, 2100, 2100, 1050, 16384) == 2100       # the end of the gap is the end
    assert aligned_stop(5, 10, 10**6, 1, 64) == 10                   # one axis / hypercube: no stride
    plan = plan_from_request({"problem": "critical_stiffness", "base": {"device": {"preset": "lhifam"}},
                              "sweep": {"device.cable.stiffness": {"start": 2e4, "stop": 1.2e5, "num": 3},
                                        "device.delay": [0.0, 0.001, 0.002],
                                        "device.cable.damping": [2.0, 3.0]}})
    assert grid_stride(plan) == 6
    runner = StudyRunner(None, lambda: None, chunk_size=64)
    ends = [start + len(values) for start, values, _ in runner._blocks(plan, [], {"per_point": 0.0625}, 1)]
    assert ends == [6, 12, 18], ends                                 # 8-point chunks (8, 16, 18): ends moved to 6, 12


def test_pace_trusts_larger_chunks_and_halves_on_equal_ones():
    pace = {"per_point": None}
    StudyRunner.update_pace(pace, 0.004, 1)          # a 1-point chunk: its fixed cost reads as a slow point
    assert pace == {"per_point": 0.004, "n": 1}
    StudyRunner.update_pace(pace, 0.005, 1000)       # measured on more points: taken as it is
    assert pace == {"per_point": 5e-6, "n": 1000}
    StudyRunner.update_pace(pace, 0.001, 1000)       # faster on as many points: at most halves
    assert pace["per_point"] == 2.5e-6
    StudyRunner.update_pace(pace, 0.1, 10)           # slower: at once, whatever the chunk
    assert pace == {"per_point": 0.01, "n": 10}


def test_a_resume_computes_only_the_gaps_and_a_stale_chunk_again(tmp_path):
    """Stored chunks are skipped by their places; a chunk whose content hash does not match the plan (other swept
    values) is dropped and computed again; the study ends with the rows of an uninterrupted run, bit for bit."""
    from service.studies.blocks import block_hash, encode_block, evaluate_block

    study = small_study(10)                                   # 20 points
    store, sid = _store_with(tmp_path, study)
    plan = plan_from_request(study)
    args = (plan.problem, dict(plan.device), dict(plan.requirements), [(a.path, a.kind) for a in plan.axes])
    v = plan.values(0, 5)
    assert store.write_chunk(sid, evaluate_block(*args, 0, v, block_hash(0, v))) == 5
    assert store.write_chunk(sid, encode_block(10, plan.values(10, 15) + 1.0, [{"x": 1.0}] * 5, [None] * 5)) == 5
    executor = _Paced(0.0)
    runner = StudyRunner(store, lambda: executor, chunk_size=64)
    runner.run_until_idle(timeout=60)
    runner.stop()
    executor.close()
    row = store.get(sid)
    assert row["status"] == "done" and row["done"] == row["total"] == 20 and row["run_start_done"] == 5
    assert sum(executor.sizes) == 15                          # 5 … 9, 10 … 14 again, 15 … 19
    fresh, fsid = _store_with(tmp_path / "fresh", study)
    StudyRunner(fresh, lambda: LocalExecutor(1), chunk_size=3).run_until_idle(timeout=60)
    assert repr(store.results(sid, 0, 100)) == repr(fresh.results(fsid, 0, 100))


def test_block_hash_names_places_and_exact_values():
    """The one hash of the studies (service.studies.blocks.block_hash, what a resume checks stored chunks by): equal
    points at two places are two points; the same request planned again (base keys in another order) gives the same
    hashes; one ulp, the sign of a zero, or another split of the same points gives another."""
    import numpy as np

    from optim.studies.problems import plan_study
    from service.studies.blocks import block_hash

    rigid = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
    sweep = {"requirements.damping": [0.0, 1.0, 0.0], "device.delay": [0.0, 0.001]}
    plan = plan_study("stability", rigid, {}, sweep)
    v = plan.values(0, plan.total)
    assert np.array_equal(v[0], v[4]) and block_hash(0, v[0:1]) != block_hash(4, v[4:5])   # a value listed twice
    again = plan_study("stability", dict(reversed(list(rigid.items()))), {}, sweep)
    assert block_hash(1, again.values(1, 5)) == block_hash(1, v[1:5])
    assert block_hash(1, np.nextafter(v[1:5], 1.0)) != block_hash(1, v[1:5])
    assert block_hash(0, -v[0:1]) != block_hash(0, v[0:1])                                  # -0.0 is not 0.0
    assert block_hash(0, v[0:4]) != block_hash(0, v[0:4].reshape(2, 4))                    # other points
    assert block_hash(0, v[0:2]) != block_hash(0, v[0:3])
