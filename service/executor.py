"""Run a numerics call where a runaway can be stopped: a worker process with a time budget.

A thread cannot be killed, so an expensive call (see :mod:`service.cost`) runs
in a worker process; past the budget the worker is killed, a fresh one is
started in its place, and the caller gets :class:`ComputeTimeout` (503).  Each
worker is a single process owned by one call at a time, so killing a stuck one
never disturbs the calls running on the others (a shared
``ProcessPoolExecutor`` would break as a whole, and Python 3.11 cannot kill its
workers without private attributes).

Calls wait in one queue served by one dispatcher thread per worker; a request
awaits its call's future from async code (:meth:`BoundedExecutor.arun`), so a
waiting request holds no thread of the server's thread pool and ``/healthz``
never starves.  The time spent in the queue counts against the budget, and
past ``max_queue`` waiting calls a new one is refused at once
(:class:`ComputeBusy`, 503 with ``Retry-After``) instead of waiting to time out.

Workers are forked from a ``forkserver`` that has already imported numpy,
scipy and the numerics (and built the CasADi design solvers: service._warm),
so a replacement is ready in milliseconds rather than the seconds a ``spawn``
costs; the server process itself (threads, sockets) is never forked.  Workers
die with the forkserver, which dies with the server (service.lifeline).
Arguments and results travel pickled: send devices and plain numbers, never
CasADi symbols (FIELD-NOTES.md).

Cheap calls run inline: the worker's round trip (~1 ms) would double the cost
of an exact rigid analysis, and the cost limits bound what an inline call can
take.  An inline call runs in a thread of a small pool, except the sub-ms ones
(estimated below ``loop_cost_ms``, e.g. an exact rigid analysis) which run on
the event loop itself: the hop to a thread and back costs ~0.1-0.4 ms, as much
as the call, and a thread computing holds the GIL and so stalls the loop
anyway.  The estimate bounds how long such a call keeps the loop (a factor of
2 of ``loop_cost_ms``, see service.cost).

Usage in a route::

    from ..executor import Compute
    async def handler(req: Req, compute: Compute):
        res = await compute.arun(some_numerics_function, device, x, cost_ms=estimate)
"""

from __future__ import annotations

import asyncio
import concurrent.futures as cf
import contextvars
import functools
import logging
import multiprocessing
import queue
import threading
import time
from dataclasses import dataclass, field
from typing import Annotated, Any, Callable, TypeVar

from fastapi import Depends, Request

from .compute_worker import Worker as _Worker
from .compute_worker import warm_worker as _warm_worker

__all__ = ["ComputeTimeout", "ComputeUnavailable", "ComputeBusy", "BoundedExecutor", "Compute", "get_executor",
           "run_bounded", "PRELOAD", "QueueState"]

T = TypeVar("T")
_log = logging.getLogger("zwidth.executor")

#: Longest wait for a new worker to start (the forkserver's first start imports numpy, scipy and the numerics).
STARTUP_TIMEOUT = 120.0
#: Modules the forkserver imports once, so that every worker starts warm.
PRELOAD = ("numpy", "scipy.optimize", "service.executor", "service.compute_worker", "service.jobs",
           "service._warm")
#: Longest wait past the budget for a started call's own end (its worker's start-up is not counted in the budget):
#: the answer is a 503 by then whatever the worker does (the dispatcher kills it at its own deadline).
OVERRUN_GRACE = 1.0
#: How long :meth:`BoundedExecutor.shutdown` lets calls in flight (and workers starting) end by themselves before it
#: kills their processes.
SHUTDOWN_GRACE = 1.0
#: Inline (cheap) calls running at once: more threads would only compete for the GIL with the event loop.
INLINE_THREADS = 4
#: Calls estimated below this [ms] run on the event loop (no thread hop); the rest of the inline ones in the pool.
LOOP_COST_MS = 2.5

class ComputeTimeout(Exception):
    """The call did not finish within its budget (its worker was killed and replaced), or waited past it."""

    def __init__(self, budget: float, waiting: bool = False):
        self.budget = budget
        self.waiting = waiting
        what = "no compute worker became free" if waiting else "the computation did not finish"
        super().__init__(f"{what} within the request time budget of {budget:g} s (ZWIDTH_REQUEST_TIMEOUT); "
                         "ask for less (fewer points, a cheaper method, a shorter delay) or raise the budget")


class ComputeUnavailable(Exception):
    """The worker died while computing (e.g. out of memory; it was replaced), or the service is stopping."""


class ComputeBusy(ComputeUnavailable):
    """Refused at once: every worker is busy and ``max_queue`` calls already wait (load shedding)."""

    def __init__(self, workers: int, max_queue: int):
        super().__init__(f"the service is busy: {workers} compute workers busy and {max_queue} requests waiting "
                         "(ZWIDTH_COMPUTE_QUEUE); retry in a moment")


@dataclass(frozen=True)
class QueueState:
    """A snapshot of the compute queue (GET /readyz)."""

    depth: int          #: calls waiting for a worker
    max_depth: int      #: waiting calls beyond which a new one is refused (503)
    workers: int        #: worker processes
    busy: int           #: workers computing now
    warm: bool          #: every worker started and warmed up (numerics imported, design solvers built)
    replaced: int       #: workers killed and replaced so far (timeouts and crashes)


@dataclass
class _Job:
    fn: Callable[..., Any]
    args: tuple
    kwargs: dict
    budget: float
    queued_at: float = field(default_factory=time.monotonic)
    future: cf.Future = field(default_factory=cf.Future)
    waiting: bool = True   # still counted in the queue depth


class BoundedExecutor:
    """``workers`` single-process workers fed from one queue; each call bounded by ``timeout`` seconds.

    One dispatcher thread per worker takes calls from the queue and owns its worker process (started
    from a forkserver that preloads :data:`PRELOAD`).  :meth:`arun` awaits a call from async code
    without holding a thread; :meth:`run` is the blocking form (tests, scripts).  Thread-safe.
    """

    def __init__(self, workers: int = 2, timeout: float = 30.0, inline_cost_ms: float = 25.0,
                 context: str = "forkserver", max_queue: int = 32, loop_cost_ms: float = LOOP_COST_MS) -> None:
        if workers < 1:
            raise ValueError("workers: must be ≥ 1")
        if not timeout > 0:
            raise ValueError("timeout: must be > 0")
        if max_queue < 0:
            raise ValueError("max_queue: must be ≥ 0")
        self.workers = workers
        self.timeout = timeout
        self.inline_cost_ms = inline_cost_ms
        self.loop_cost_ms = min(loop_cost_ms, inline_cost_ms)
        self.max_queue = max_queue
        self._ctx = multiprocessing.get_context(context)
        if context == "forkserver":
            # Effective only if this process has not started its forkserver yet; harmless otherwise.
            self._ctx.set_forkserver_preload(list(PRELOAD))
        self._jobs: queue.SimpleQueue[_Job | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._dispatchers: list[threading.Thread] = []
        self._live: dict[int, _Worker] = {}     # dispatcher slot -> its worker (for shutdown and tests)
        self._replacing: dict[int, tuple[float, float]] = {}   # slot -> (start, end) of its last worker replacement
        self._waiting = 0
        self._busy = 0
        self._closed = False
        self._warmed: list[threading.Event] = []
        self._inline = cf.ThreadPoolExecutor(max_workers=INLINE_THREADS, thread_name_prefix="zwidth-inline")
        self.warm = False
        """Every worker started and warmed (set by :meth:`warm_up`)."""
        self.replaced = 0
        """How many workers were killed and replaced (timeouts and crashes)."""

    # -- state ----------------------------------------------------------------------------------
    def state(self) -> QueueState:
        with self._lock:
            return QueueState(depth=self._waiting, max_depth=self.max_queue, workers=self.workers, busy=self._busy,
                              warm=self.warm, replaced=self.replaced)

    def worker_pids(self) -> list[int]:
        """Process ids of the live workers."""
        with self._lock:
            return [w.process.pid for w in self._live.values() if w.process.pid is not None]

    # -- dispatchers ------------------------------------------------------------------------------
    def _ensure_dispatchers(self, prestart: bool) -> None:
        with self._lock:
            if self._closed:
                raise ComputeUnavailable("the service is shutting down")
            if len(self._dispatchers) == self.workers and all(t.is_alive() for t in self._dispatchers):
                return
            alive = [t for t in self._dispatchers if t.is_alive()]
            self._dispatchers = alive
            self._warmed = []
            for slot in range(len(alive), self.workers):
                ev = threading.Event()
                self._warmed.append(ev)
                t = threading.Thread(target=self._dispatch, args=(slot, prestart, ev), daemon=True,
                                     name=f"zwidth-dispatch-{slot}")
                self._dispatchers.append(t)
                t.start()

    def _start(self, slot: int) -> _Worker:
        worker = _Worker(self._ctx)
        with self._lock:
            self._live[slot] = worker
        return worker

    def _drop(self, slot: int, worker: _Worker | None) -> None:
        if worker is None:
            return
        worker.kill()
        with self._lock:
            if self._live.get(slot) is worker:
                del self._live[slot]

    def _dispatch(self, slot: int, prestart: bool, warmed: threading.Event) -> None:
        worker: _Worker | None = None
        if prestart:
            try:
                worker = self._start(slot)
                worker.wait_ready(STARTUP_TIMEOUT)
                ok, value = worker.call(_warm_worker, (), {}, STARTUP_TIMEOUT)
                if not ok:
                    raise value
            except Exception:  # noqa: BLE001 - the first call starts one itself
                _log.exception("could not start and warm a compute worker")
                self._drop(slot, worker)
                worker = None
        warmed.set()
        while True:
            job = self._jobs.get()
            if job is None:
                break
            with self._lock:
                if job.waiting:
                    job.waiting = False
                    self._waiting -= 1
                if not job.future.set_running_or_notify_cancel():
                    continue
                self._busy += 1
            try:
                worker = self._execute(slot, worker, job)
            except BaseException as exc:  # noqa: BLE001 - never leave a caller waiting
                if not job.future.done():
                    job.future.set_exception(exc)
            finally:
                with self._lock:
                    self._busy -= 1
        self._drop(slot, worker)

    def _execute(self, slot: int, worker: _Worker | None, job: _Job) -> _Worker | None:
        """Run ``job`` on ``worker`` (started if needed); returns the worker to use next."""
        remaining = job.budget - (time.monotonic() - job.queued_at) + self._replacement_credit(slot, job)
        if remaining <= 0:
            job.future.set_exception(ComputeTimeout(job.budget, waiting=True))
            return worker
        t0 = time.monotonic()
        try:
            if worker is None:
                worker = self._start(slot)
            worker.wait_ready(STARTUP_TIMEOUT)
        except (TimeoutError, EOFError, OSError):
            self._drop(slot, worker)
            with self._lock:
                self.replaced += 1
            job.future.set_exception(ComputeUnavailable("a compute worker failed to start; it was replaced"))
            return None
        remaining += time.monotonic() - t0   # a worker's start-up is not the caller's computation
        try:
            ok, value = worker.call(job.fn, job.args, job.kwargs, remaining)
        except TimeoutError:
            # The caller's 503 first, then the kill and the re-fork (they took the answer past the budget under
            # CPU contention: a 10 s budget answered at 13.8 s, issue 28).
            self._count_replaced()
            job.future.set_exception(ComputeTimeout(job.budget))
            _log.warning("compute budget exceeded; worker killed and replaced",
                         extra={"budget_s": job.budget, "function": getattr(job.fn, "__qualname__", str(job.fn))})
            return self._replace_timed(slot, worker)
        except (EOFError, OSError) as exc:
            self._count_replaced()
            job.future.set_exception(
                ComputeUnavailable("the compute worker died during the computation; it was replaced"))
            _log.error("compute worker died; replaced", extra={"error": type(exc).__name__})
            return self._replace_timed(slot, worker)
        except Exception as exc:  # noqa: BLE001 - e.g. unpicklable arguments: nothing reached the worker
            job.future.set_exception(exc)
            return worker
        if ok:
            job.future.set_result(value)
        else:
            job.future.set_exception(value)
        return worker

    def _replace_timed(self, slot: int, worker: _Worker) -> _Worker | None:
        """:meth:`_replace` (already counted), remembering when this slot was busy with it: a call that waited in
        the queue meanwhile is not charged for it (a worker's start-up is not the caller's computation)."""
        t0 = time.monotonic()
        try:
            return self._replace(slot, worker, counted=True)
        finally:
            self._replacing[slot] = (t0, time.monotonic())

    def _replacement_credit(self, slot: int, job: _Job) -> float:
        """Seconds of ``job``'s wait in the queue that this slot spent replacing its worker."""
        span = self._replacing.get(slot)
        if span is None:
            return 0.0
        return max(0.0, span[1] - max(span[0], job.queued_at))

    def _count_replaced(self) -> None:
        with self._lock:
            self.replaced += 1

    def _replace(self, slot: int, worker: _Worker, counted: bool = False) -> _Worker | None:
        self._drop(slot, worker)
        if not counted:
            self._count_replaced()
        try:  # a fork of the warm forkserver: ready by the next call
            return self._start(slot)
        except Exception:  # noqa: BLE001 - the next call starts one itself
            _log.exception("could not start a replacement compute worker")
            return None

    # -- calls ------------------------------------------------------------------------------------
    def submit(self, fn: Callable[..., T], *args: Any, timeout: float | None = None, **kwargs: Any) -> cf.Future:
        """Queue ``fn(*args, **kwargs)`` for a worker; the budget runs from now (:class:`ComputeBusy` if full)."""
        self._ensure_dispatchers(prestart=False)
        job = _Job(fn, args, kwargs, self.timeout if timeout is None else timeout)
        with self._lock:
            if self._closed:
                raise ComputeUnavailable("the service is shutting down")
            if self._waiting + self._busy >= self.workers + self.max_queue:
                raise ComputeBusy(self.workers, self.max_queue)
            self._waiting += 1
        job.future.zwidth_job = job  # type: ignore[attr-defined]
        self._jobs.put(job)
        return job.future

    def _withdraw(self, fut: cf.Future) -> bool:
        """Take a call out of the queue if no worker has started it (True), else leave it running."""
        job: _Job = fut.zwidth_job  # type: ignore[attr-defined]
        with self._lock:   # the dispatcher starts a call under the same lock
            if not fut.cancel():
                return False
            if job.waiting:
                job.waiting = False
                self._waiting -= 1
            return True

    def run(self, fn: Callable[..., T], *args: Any, cost_ms: float | None = None,
            timeout: float | None = None, **kwargs: Any) -> T:
        """``fn(*args, **kwargs)``, blocking; inline when ``cost_ms`` is below the inline threshold, else in a
        worker.  ``cost_ms=None`` always uses a worker.  Raises what ``fn`` raises, :class:`ComputeTimeout`
        past the budget, :class:`ComputeUnavailable` if the worker died or the queue is full."""
        if cost_ms is not None and cost_ms < self.inline_cost_ms:
            return fn(*args, **kwargs)
        budget = self.timeout if timeout is None else timeout
        fut = self.submit(fn, *args, timeout=budget, **kwargs)
        try:
            return fut.result(timeout=budget)
        except cf.TimeoutError:
            if self._withdraw(fut):
                raise ComputeTimeout(budget, waiting=True) from None
            return fut.result()   # started: the dispatcher stops it at the budget

    async def arun(self, fn: Callable[..., T], *args: Any, cost_ms: float | None = None,
                   timeout: float | None = None, **kwargs: Any) -> T:
        """As :meth:`run`, awaited: a call waiting for (or running in) a worker holds no thread.

        An inline call runs in a small thread pool, or on the event loop below ``loop_cost_ms``."""
        if cost_ms is not None and cost_ms < self.loop_cost_ms:
            return fn(*args, **kwargs)
        loop = asyncio.get_running_loop()
        if cost_ms is not None and cost_ms < self.inline_cost_ms:
            ctx = contextvars.copy_context()   # the request id of the logs
            return await loop.run_in_executor(self._inline, functools.partial(ctx.run, fn, *args, **kwargs))
        budget = self.timeout if timeout is None else timeout
        fut = self.submit(fn, *args, timeout=budget, **kwargs)
        waiter = asyncio.wrap_future(fut, loop=loop)
        try:
            return await asyncio.wait_for(asyncio.shield(waiter), budget)
        except asyncio.TimeoutError:
            if self._withdraw(fut):
                raise ComputeTimeout(budget, waiting=True) from None
            # started: the dispatcher stops it at the budget (plus the worker's start-up, which is not the
            # caller's); the answer waits no more than OVERRUN_GRACE for that
            try:
                return await asyncio.wait_for(asyncio.shield(waiter), OVERRUN_GRACE)
            except asyncio.TimeoutError:
                waiter.add_done_callback(lambda f: f.cancelled() or f.exception())   # nobody reads it now
                raise ComputeTimeout(budget) from None
        except asyncio.CancelledError:
            if not self._withdraw(fut):   # the request went away: a call not yet started never runs
                waiter.add_done_callback(lambda f: f.cancelled() or f.exception())   # nobody reads it now
            raise

    # -- life cycle -------------------------------------------------------------------------------
    def warm_up(self, timeout: float = STARTUP_TIMEOUT) -> bool:
        """Start every worker now and warm it (blocking); True when all are ready (then :attr:`warm`)."""
        try:
            self._ensure_dispatchers(prestart=True)
        except ComputeUnavailable:   # shut down while warming up (an app stopped at once)
            return False
        deadline = time.monotonic() + timeout
        for ev in list(self._warmed):
            if not ev.wait(max(deadline - time.monotonic(), 0.0)):
                return False
        with self._lock:
            self.warm = len(self._live) == self.workers and not self._closed
            return self.warm

    def open(self) -> None:
        """Accept work again after :meth:`shutdown` (an app's lifespan may run more than once, e.g. in tests)."""
        with self._lock:
            self._closed = False

    def shutdown(self) -> None:
        """Refuse new calls, fail the queued ones; calls in flight get :data:`SHUTDOWN_GRACE` to finish (their
        processes are killed after it, and so are workers still starting), then every worker is killed."""
        with self._lock:
            self._closed = True
            self.warm = False
            dispatchers, self._dispatchers = self._dispatchers, []
        while True:
            try:
                job = self._jobs.get_nowait()
            except queue.Empty:
                break
            if job is not None and job.future.set_running_or_notify_cancel():
                with self._lock:
                    if job.waiting:
                        job.waiting = False
                        self._waiting -= 1
                job.future.set_exception(ComputeUnavailable("the service is shutting down"))
        for _ in dispatchers:
            self._jobs.put(None)
        others = [t for t in dispatchers if t is not threading.current_thread()]
        deadline = time.monotonic() + SHUTDOWN_GRACE
        for t in others:
            t.join(timeout=max(deadline - time.monotonic(), 0.0))
        if any(t.is_alive() for t in others):
            # A call still running past the grace, or a worker still starting (e.g. the replacement of one killed at
            # its budget): its process is killed, so its dispatcher sees the pipe close and ends now, not after the
            # call or the start-up (a test app's lifespan ended this way waited up to 10 s, the fuzz's teardowns).
            with self._lock:
                stuck = list(self._live.values())
            for worker in stuck:
                worker.process.kill()
            for t in others:
                t.join(timeout=10)

def _executor_of(request: Request) -> BoundedExecutor:
    return request.app.state.executor


async def get_executor(request: Request) -> BoundedExecutor:
    """The app's executor.  ``async`` on purpose: FastAPI runs a plain ``def`` dependency in its thread pool,
    a hop of ~0.1-0.2 ms per request (measured: most of the HTTP overhead of an exact rigid analysis)."""
    return _executor_of(request)


#: Dependency alias for routes: ``compute: Compute`` then ``await compute.arun(fn, *args, cost_ms=...)``.
Compute = Annotated[BoundedExecutor, Depends(get_executor)]


def run_bounded(request: Request, fn: Callable[..., T], *args: Any, cost_ms: float | None = None,
                **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` under the app's time budget (see :meth:`BoundedExecutor.run`)."""
    return _executor_of(request).run(fn, *args, cost_ms=cost_ms, **kwargs)
