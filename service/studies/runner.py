"""The study runner: one coordinator thread that schedules chunks on an executor and writes results.

The coordinator is the store's only writer of results.  It takes the oldest queued or running
study (so a study interrupted by a crash resumes at the next start), plans only the points no
stored chunk covers (a stored chunk whose content hash no longer matches the plan is dropped and
planned again), keeps a bounded number of chunks in flight, and writes each chunk's block in one
transaction as it completes.  It handles chunks, never points: a chunk is its first point, the
swept values of its points as one numpy array and their content hash, and comes back as one block
(service.studies.blocks), so a 10-million-point study never exists as Python objects here.  A task that failed (a worker killed, a broken pool) is
resubmitted; after three attempts the study is marked ``failed`` with the error, never
completed with made-up points.

A cancel may come through any service process: the store then refuses this coordinator's next
chunk (store.write_chunk), and the coordinator also reads the study's state at every poll while
it waits for chunks; either way it stops scheduling, drops the chunks in flight and turns
``cancelling`` into ``cancelled`` — within one chunk (or one poll) of the cancel.
"""

from __future__ import annotations

import logging
import math
import os
import socket
import threading
import time
import uuid
from concurrent.futures import CancelledError
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Iterator

import numpy as np

from optim.studies.problems import StudyInputError, StudyPlan, get_problem, plan_study

from .blocks import block_hash, evaluate_block, evaluate_planned
from .config import StudySettings
from .executors import Executor
from .store import StudyStore

__all__ = ["StudyRunner", "plan_from_request"]

log = logging.getLogger("zwidth.studies")

_MAX_ATTEMPTS = 3
_RENEW_EVERY = 5.0  # [s] lease renewal (the lease is store.LEASE_SECONDS)
#: A chunk is sized to take about this long (from the measured time per point), so that `done` moves at least
#: this often: a study of slow points advances point by point instead of sitting at 0 for a whole chunk.
CHUNK_SECONDS = 0.5
#: The smallest chunk worth a task at the end of a study [s of work]: below it a task's round trip (a few ms, more
#: through a Dask scheduler) outweighs the imbalance between the workers it would even out.
MIN_CHUNK_SECONDS = 0.02


def grid_stride(plan: StudyPlan) -> int:
    """Points of a grid that share their first axis's value (the product of the other axes' lengths; 1 for one axis
    or a Latin hypercube): the chunk ends the runner prefers (aligned_stop)."""
    if plan.design != "grid" or len(plan.axes) < 2:
        return 1
    return math.prod(len(a.values) for a in plan.axes[1:])


def aligned_stop(at: int, stop: int, hi: int, stride: int, largest: int) -> int:
    """``stop`` moved to the nearest multiple of ``stride`` (issue 32), when the chunk at..stop then keeps between half
    and twice its size (and at most ``largest`` points); else ``stop`` as it is.

    A chunk then holds every point of each value of the grid's first axis it touches: a damped cable's points that
    differ only in the delay (optim.studies.cable_chunks: one modal factoring each, ≈ 0.5 ms) are not split over two
    chunks that would each factor them (the cable grid's chunks under load were ≈ 1,000 points against 1,050-point
    blocks: nearly every factoring was done twice).  Rows do not depend on their chunk, so no row changes."""
    if stride <= 1 or stop >= hi:
        return stop
    size = stop - at
    down = stop - stop % stride
    ends = (down, down + stride) if stop - down <= down + stride - stop else (down + stride, down)
    for end in ends:
        if at < end < hi and size <= 2 * (end - at) and end - at <= min(2 * size, largest):
            return end
    return stop


def plan_from_request(request: dict[str, Any]) -> StudyPlan:
    base = request.get("base") or {}
    return plan_study(request["problem"], base.get("device") or {}, base.get("requirements") or {},
                      request.get("sweep") or {}, request.get("sampling"), max_points=StudySettings().max_points,
                      controller=base.get("controller"))


class StudyRunner:
    """Runs studies from ``store`` on the executor made by ``executor_factory`` (see module docstring)."""

    def __init__(self, store: StudyStore, executor_factory: Callable[[], Executor], chunk_size: int = 64,
                 in_flight_per_slot: int = 2, poll: float = 0.5):
        self.store = store
        self._factory = executor_factory
        self.executor: Executor | None = None
        self.chunk_size = chunk_size
        self.in_flight_per_slot = in_flight_per_slot
        self.poll = poll
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._cancelled: set[str] = set()
        self._thread: threading.Thread | None = None
        self.current: str | None = None
        # host:pid:nonce — another process on this host can tell a crashed owner from a live one.
        self.owner = f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:8]}"

    # -- control --------------------------------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self._loop, name="zwidth-study-coordinator", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 30.0) -> None:
        """Stop scheduling; running studies stay ``running`` in the store and resume at the next start."""
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout)
        if self.executor is not None:
            self.executor.close()
            self.executor = None

    def notify(self) -> None:
        self._wake.set()

    def cancel(self, study_id: str) -> None:
        self._cancelled.add(study_id)
        self._wake.set()

    def run_until_idle(self, timeout: float = 600.0) -> None:
        """Run every active study in the calling thread (tests, CLI local runs, benchmarks)."""
        deadline = time.monotonic() + timeout
        while not self._stop.is_set() and time.monotonic() < deadline:
            ids = self.store.active_ids(self.owner)
            if not ids:
                return
            self._run(ids[0])

    # -- coordinator ----------------------------------------------------------------------------
    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                self.store.settle_cancels()
                ids = self.store.active_ids(self.owner)
                if ids:
                    self._run(ids[0])
                    continue
            except Exception:  # noqa: BLE001 - the coordinator must survive a bad database moment
                log.exception("study coordinator error; retrying")
                self._stop.wait(2.0)
            self._wake.wait(self.poll)
            self._wake.clear()

    def _executor(self) -> Executor:
        if self.executor is None:
            self.executor = self._factory()
        return self.executor

    def chunk_size_for(self, problem: str) -> int:
        """Points per chunk for this problem: the runner's chunk size times the problem's chunk_factor."""
        try:
            return self.chunk_size * get_problem(problem).chunk_factor
        except StudyInputError:   # unknown or unavailable: the study fails where it is planned, not here
            return self.chunk_size

    @staticmethod
    def gaps(total: int, stored: list[tuple[int, int, str]]) -> Iterator[tuple[int, int]]:
        """[start, stop) ranges of the points no stored chunk covers, in order."""
        at = 0
        for start, n, _ in stored:
            if start > at:
                yield at, start
            at = max(at, start + n)
        if at < total:
            yield at, total

    def stale_chunks(self, plan: StudyPlan, stored: list[tuple[int, int, str]]) -> list[int]:
        """Starts of stored chunks whose points are not the plan's any more (their content hash differs, or they
        overlap another chunk or the plan's end): dropped and planned again, so a resume is exact."""
        stale, end = [], 0
        for start, n, digest in stored:
            if start < end or start + n > plan.total or block_hash(start, plan.values(start, start + n)) != digest:
                stale.append(start)
            else:
                end = start + n
        return stale

    def adaptive_size(self, largest: int, seconds_per_point: float | None, remaining: int, parallel: int) -> int:
        """Points in the next chunk: one while the time per point is unknown, then what takes CHUNK_SECONDS
        (at most ``largest``, the configured chunk), and no more than an even share of what is left among the
        chunks that run in parallel (so the last points spread over the workers and progress keeps moving) —
        but never a share under MIN_CHUNK_SECONDS of work: the last 1 % of a fast study in chunks of 1 … 16 points
        (each a round trip to a worker, tens of them) cost more than the imbalance they avoid."""
        if seconds_per_point is None:
            return 1
        size = largest if seconds_per_point <= 0 else int(CHUNK_SECONDS / seconds_per_point)
        share = -(-remaining // max(1, parallel))
        floor = largest if seconds_per_point <= 0 else int(MIN_CHUNK_SECONDS / seconds_per_point)
        return max(1, min(largest, size, max(share, floor)))

    @staticmethod
    def update_pace(pace: dict[str, Any], seconds: float, n: int) -> None:
        """Fold a chunk's worker time into ``pace`` ({"per_point": s or None, "n": points it was measured on}).

        A slower chunk counts at once (a slow region shrinks the chunks); a faster one at most halves the estimate,
        unless it was measured on more points than the estimate was: a chunk's fixed cost (a few ms) made a 1-point
        chunk read as a slow point, and halving from there took ~9 round trips to reach the full chunk."""
        per = seconds / max(1, n)
        prev = pace.get("per_point")
        if prev is None or per >= prev or n > pace.get("n", 0):
            pace["per_point"], pace["n"] = per, n
        else:
            pace["per_point"] = max(per, 0.5 * prev)

    def _blocks(self, plan: StudyPlan, stored: list[tuple[int, int, str]], pace: dict[str, Any] | None = None,
                parallel: int = 1, scale: int = 1) -> Iterator[tuple[int, np.ndarray, str]]:
        """Chunks (start, swept values, content hash) of the points to do; with ``pace`` ({"per_point": seconds or
        None}, updated by the caller as chunks come back) each chunk is sized by adaptive_size, else every chunk
        has the configured size; ``scale`` multiplies the largest chunk (the executor's task_scale).  Values are
        planned a chunk at a time: memory is one chunk's."""
        largest = self.chunk_size_for(plan.problem) * max(1, scale)
        remaining = plan.total - sum(n for _, n, _ in stored)
        stride = grid_stride(plan)
        for lo, hi in self.gaps(plan.total, stored):
            at = lo
            while at < hi:
                size = largest if pace is None else self.adaptive_size(largest, pace["per_point"], remaining,
                                                                       parallel)
                # a chunk of one point (the first, which measures the pace, or one point's worth of the time
                # budget) stays one point: aligning would double it
                stop = min(hi, at + size) if size <= 1 else aligned_stop(at, min(hi, at + size), hi, stride, largest)
                values = plan.values(at, stop)
                yield at, values, block_hash(at, values)
                remaining -= stop - at
                at = stop

    def _should_stop(self, study_id: str) -> bool:
        return self._stop.is_set() or study_id in self._cancelled

    def _run(self, study_id: str) -> None:
        row = self.store.begin_run(study_id, self.owner)
        if row is None:  # cancelled meanwhile, or another live coordinator holds it
            return
        self.current = study_id
        try:
            self._run_plan(study_id, row)
        except Exception as exc:
            # e.g. the Dask scheduler is unreachable: the study stays active and says why; the loop retries
            # the exception's text (hosts, ports, paths) goes to the log only; the study says the type
            log.warning("study %s: run interrupted (%s: %s); retrying", study_id, type(exc).__name__, exc)
            self.store.set_error(study_id, f"retrying after {type(exc).__name__} (the detail is in the server log)")
            raise
        finally:
            self.current = None
            self._cancelled.discard(study_id)

    def _run_plan(self, study_id: str, row: dict) -> None:
        try:
            plan = plan_from_request(row["request"])
        except (StudyInputError, KeyError, TypeError) as exc:  # e.g. a design module removed from the build
            log.warning("study %s: stored request cannot be planned: %r", study_id, exc)
            why = f"{exc.field}: {exc.rule}" if isinstance(exc, StudyInputError) else f"{type(exc).__name__} (see the log)"
            self.store.finish(study_id, "failed", f"the stored request cannot be planned: {why}", owner=self.owner)
            return
        executor = self._executor()
        args = (plan.problem, dict(plan.device), dict(plan.requirements), [(a.path, a.kind) for a in plan.axes])
        limit = max(1, executor.slots * self.in_flight_per_slot)
        pace: dict[str, Any] = {"per_point": None}   # seconds per point, measured from the chunks that came back
        stored = self.store.stored_chunks(study_id)
        stale = self.stale_chunks(plan, stored)
        if stale:
            log.warning("study %s: %d stored chunks do not match the plan; computing them again", study_id,
                        len(stale))
            if self.store.drop_chunks(study_id, stale, self.owner) is None:
                return
            stored = self.store.stored_chunks(study_id)
        todo = self._blocks(plan, stored, pace, limit, getattr(executor, "task_scale", 1))
        # a grid's plan is small (its axes): where the executor keeps it on its workers (Dask), a task carries its
        # chunk's place, not its values; a retry carries the values (a scattered plan dies with all the workers)
        shared = executor.share(plan) if plan.design == "grid" and hasattr(executor, "share") else None

        def submit(chunk: tuple, attempt: int) -> Any:
            if shared is not None and attempt == 1:
                return executor.submit(evaluate_planned, shared, chunk[0], len(chunk[1]))
            return executor.submit(evaluate_block, *args, *chunk)

        # where the run's time goes (logged when it ends): the workers' compute, the coordinator's waits and writes
        t_run, busy, waited, wrote, n_chunks = time.monotonic(), 0.0, 0.0, 0.0, 0
        pending: dict[Any, tuple[tuple, int]] = {}
        started: dict[Any, float] = {}
        exhausted = False
        last_check = time.monotonic()
        while True:
            if self._should_stop(study_id):
                executor.cancel(set(pending))
                if not self._stop.is_set():   # cancelled (not a shutdown): say that it stopped
                    self.store.finish(study_id, "cancelled", owner=self.owner)
                return
            while not exhausted and len(pending) < limit:
                chunk = next(todo, None)
                if chunk is None:
                    exhausted = True
                    break
                fut = submit(chunk, 1)
                pending[fut], started[fut] = (chunk, 1), time.monotonic()
            if not pending:
                break
            t_wait = time.monotonic()
            done, _ = executor.wait(set(pending), timeout=self.poll)
            waited += time.monotonic() - t_wait
            for fut in done:
                chunk, attempt = pending.pop(fut)
                t0 = started.pop(fut, None)
                try:
                    out = fut.result()
                except (CancelledError, Exception) as exc:  # noqa: BLE001 - resubmitted or reported below
                    if isinstance(exc, BrokenProcessPool):
                        executor.reset()
                    if attempt >= _MAX_ATTEMPTS:
                        executor.cancel(set(pending))
                        self.store.finish(study_id, "failed",
                                          f"a chunk failed {attempt} times ({type(exc).__name__}; the "
                                          "detail is in the server log)",
                                          owner=self.owner)
                        return
                    log.warning("study %s: chunk failed (%s: %s), resubmitting", study_id, type(exc).__name__, exc)
                    retry = submit(chunk, attempt + 1)
                    pending[retry], started[retry] = (chunk, attempt + 1), time.monotonic()
                    continue
                if t0 is not None:
                    # the worker's own time per point (a chunk's wall time here counts its wait in the queue: a small
                    # chunk queued behind large ones read that wait as compute time and shrank every following
                    # chunk, a stability study fell to 1-point chunks); a slow region shrinks chunks at once
                    seconds = out.seconds if out.seconds > 0 else time.monotonic() - t0   # untimed: the wall time
                    self.update_pace(pace, seconds, len(chunk[1]))
                    busy += seconds
                if (out.start, out.n, out.digest) != (chunk[0], len(chunk[1]), chunk[2]):
                    raise RuntimeError(f"a worker returned the block of other points ({out.start}, {out.n}) "
                                       f"for the chunk at {chunk[0]} of {len(chunk[1])}")
                t_write = time.monotonic()
                written = self.store.write_chunk(study_id, out, self.owner)
                wrote += time.monotonic() - t_write
                n_chunks += 1
                if written is None:
                    self._cancelled.add(study_id)   # cancelled (through any server) or taken over: stop now
                    break
            # A cancel through another process (no chunk came back to find it); keep the lease.
            if self.store.status(study_id) != "running":
                self._cancelled.add(study_id)
            elif time.monotonic() - last_check > _RENEW_EVERY:
                last_check = time.monotonic()
                if not self.store.renew(study_id, self.owner):
                    self._cancelled.add(study_id)
        self.store.finish(study_id, "done", owner=self.owner)
        log.info("study %s done on %s: %d chunks in %.3f s; workers computed %.3f s, the coordinator waited %.3f s "
                 "and wrote %.3f s", study_id, executor.kind, n_chunks, time.monotonic() - t_run, busy, waited, wrote)
