"""Run a numerics call where a runaway can be stopped: a worker process with a time budget.

A thread cannot be killed, so an expensive call (see :mod:`service.cost`) runs
in a worker process; past the budget the worker is killed, a fresh one is
started in its place, and the caller gets :class:`ComputeTimeout` (503).  Each
worker is a single process owned by one call at a time, so killing a stuck one
never disturbs the calls running on the others (a shared
``ProcessPoolExecutor`` would break as a whole, and Python 3.11 cannot kill its
workers without private attributes).

Workers are forked from a ``forkserver`` that has already imported numpy,
scipy and the numerics, so a replacement is ready in milliseconds rather than
the second a ``spawn`` costs; the server process itself (threads, sockets) is
never forked.  Arguments and results travel pickled: send devices and plain
numbers, never CasADi symbols (FIELD-NOTES.md).

Cheap calls run inline in the request thread: the pool's round trip (~1 ms)
would double the cost of an exact rigid analysis, and the cost limits bound
what an inline call can take.

Usage in a route::

    from ..executor import Compute
    def handler(req: Req, compute: Compute):
        res = compute.run(some_numerics_function, device, x, cost_ms=estimate)
"""

from __future__ import annotations

import logging
import multiprocessing
import threading
import time
from multiprocessing.connection import Connection
from typing import Annotated, Any, Callable, TypeVar

from fastapi import Depends, Request

__all__ = ["ComputeTimeout", "ComputeUnavailable", "BoundedExecutor", "Compute", "get_executor", "run_bounded",
           "PRELOAD"]

T = TypeVar("T")
_log = logging.getLogger("zwidth.executor")

#: Longest wait for a new worker to start (the forkserver's first start imports numpy, scipy and the numerics).
STARTUP_TIMEOUT = 60.0
#: Modules the forkserver imports once, so that every worker starts warm.
PRELOAD = ("numpy", "scipy.optimize", "service.executor", "service.jobs", "service._warm")


class ComputeTimeout(Exception):
    """The call did not finish within its budget; its worker was killed and replaced."""

    def __init__(self, budget: float, waiting: bool = False):
        self.budget = budget
        self.waiting = waiting
        what = "no compute worker became free" if waiting else "the computation did not finish"
        super().__init__(f"{what} within the request time budget of {budget:g} s (ZWIDTH_REQUEST_TIMEOUT); "
                         "ask for less (fewer points, a cheaper method, a shorter delay) or raise the budget")


class ComputeUnavailable(Exception):
    """The worker died while computing (e.g. out of memory); it was replaced."""


def _serve(conn: Connection) -> None:
    """Worker loop: say "ready", then receive (fn, args, kwargs), send back ("ok", value) or ("err", exception)."""
    conn.send(("ready", None))
    while True:
        try:
            fn, args, kwargs = conn.recv()
        except (EOFError, OSError):
            return
        try:
            reply: tuple[str, Any] = ("ok", fn(*args, **kwargs))
        except Exception as exc:  # noqa: BLE001 - re-raised in the caller, where it is mapped
            reply = ("err", exc)
        try:
            conn.send(reply)
        except Exception as exc:  # noqa: BLE001 - an unpicklable result or exception
            conn.send(("err", RuntimeError(f"worker could not return its result ({type(exc).__name__})")))


class _Worker:
    def __init__(self, ctx: Any) -> None:
        parent, child = ctx.Pipe()
        self.process = ctx.Process(target=_serve, args=(child,), name="zwidth-compute", daemon=True)
        self.process.start()
        child.close()
        self.conn: Connection = parent
        self.ready = False

    def wait_ready(self, timeout: float) -> None:
        """Wait for the worker's greeting: its start-up (a fork, or the forkserver's first start with
        imports) is not the caller's computation and does not count against the request budget."""
        if self.ready:
            return
        if not self.conn.poll(timeout):
            raise TimeoutError
        self.conn.recv()
        self.ready = True

    def call(self, fn: Callable[..., T], args: tuple, kwargs: dict, timeout: float) -> tuple[bool, Any]:
        """(True, value) or (False, exception raised by fn); TimeoutError past ``timeout``, EOFError if it died."""
        self.conn.send((fn, args, kwargs))
        if not self.conn.poll(max(timeout, 0.0)):
            raise TimeoutError
        status, value = self.conn.recv()
        return status == "ok", value

    def kill(self) -> None:
        self.process.kill()
        self.process.join(timeout=5)
        self.conn.close()


class BoundedExecutor:
    """``workers`` single-process workers, each call bounded by ``timeout`` seconds.

    Processes start lazily (on the first expensive call) from a forkserver that
    preloads :data:`PRELOAD`.  Thread-safe: sync handlers call :meth:`run` from
    the server's thread pool.
    """

    def __init__(self, workers: int = 2, timeout: float = 30.0, inline_cost_ms: float = 25.0,
                 context: str = "forkserver") -> None:
        if workers < 1:
            raise ValueError("workers: must be ≥ 1")
        if not timeout > 0:
            raise ValueError("timeout: must be > 0")
        self.workers = workers
        self.timeout = timeout
        self.inline_cost_ms = inline_cost_ms
        self._ctx = multiprocessing.get_context(context)
        if context == "forkserver":
            # Effective only if this process has not started its forkserver yet; harmless otherwise.
            self._ctx.set_forkserver_preload(list(PRELOAD))
        self._slots = threading.BoundedSemaphore(workers)
        self._idle: list[_Worker] = []
        self._lock = threading.Lock()
        self._closed = False
        self.replaced = 0
        """How many workers were killed and replaced (timeouts and crashes)."""

    def _take(self) -> _Worker:
        with self._lock:
            if self._closed:
                raise ComputeUnavailable("the service is shutting down")
            if self._idle:
                return self._idle.pop()
        return _Worker(self._ctx)

    def _give(self, worker: _Worker) -> None:
        with self._lock:
            if not self._closed:
                self._idle.append(worker)
                return
        worker.kill()

    def _replace(self, worker: _Worker) -> None:
        worker.kill()
        self.replaced += 1
        # Start the successor now (a fork of the warm forkserver) so the next request finds it ready.
        try:
            self._give(_Worker(self._ctx))
        except Exception:  # noqa: BLE001 - the next call starts one itself
            _log.exception("could not start a replacement compute worker")

    def run(self, fn: Callable[..., T], *args: Any, cost_ms: float | None = None,
            timeout: float | None = None, **kwargs: Any) -> T:
        """``fn(*args, **kwargs)``; inline when ``cost_ms`` is below the inline threshold, else in a worker.

        ``cost_ms=None`` always uses a worker.  Raises what ``fn`` raises,
        :class:`ComputeTimeout` past the budget, :class:`ComputeUnavailable` if the worker died.
        """
        if cost_ms is not None and cost_ms < self.inline_cost_ms:
            return fn(*args, **kwargs)
        budget = self.timeout if timeout is None else timeout
        t0 = time.monotonic()
        if not self._slots.acquire(timeout=budget):
            raise ComputeTimeout(budget, waiting=True)
        queued = time.monotonic() - t0  # waiting for a free worker counts against the budget
        try:
            worker = self._take()
            try:
                worker.wait_ready(STARTUP_TIMEOUT)
            except (TimeoutError, EOFError, OSError):
                self._replace(worker)
                raise ComputeUnavailable("a compute worker failed to start; it was replaced") from None
            deadline = time.monotonic() + budget - queued
            try:
                ok, value = worker.call(fn, args, kwargs, deadline - time.monotonic())
            except TimeoutError:
                _log.warning("compute budget exceeded; worker killed and replaced",
                             extra={"budget_s": budget, "function": getattr(fn, "__qualname__", str(fn))})
                self._replace(worker)
                raise ComputeTimeout(budget) from None
            except (EOFError, OSError) as exc:
                _log.error("compute worker died; replaced", extra={"error": type(exc).__name__})
                self._replace(worker)
                raise ComputeUnavailable("the compute worker died during the computation; it was replaced") from None
            except BaseException:
                # e.g. unpicklable arguments: nothing reached the worker, which stays usable.
                self._give(worker)
                raise
            self._give(worker)
        finally:
            self._slots.release()
        if ok:
            return value
        raise value

    def warm_up(self) -> None:
        """Start every worker now (optional: they otherwise start on first use)."""
        started = []
        try:
            for _ in range(self.workers):
                if self._slots.acquire(blocking=False):
                    try:
                        started.append(self._take())
                    except ComputeUnavailable:   # shut down while warming up (an app stopped at once)
                        self._slots.release()
                        return
            for w in started:
                w.wait_ready(STARTUP_TIMEOUT)
        finally:
            for w in started:
                self._give(w)
                self._slots.release()

    def open(self) -> None:
        """Accept work again after :meth:`shutdown` (an app's lifespan may run more than once, e.g. in tests)."""
        with self._lock:
            self._closed = False

    def shutdown(self) -> None:
        """Kill the idle workers; calls in flight finish, then their workers are killed too."""
        with self._lock:
            self._closed = True
            idle, self._idle = self._idle, []
        for w in idle:
            w.kill()


def get_executor(request: Request) -> BoundedExecutor:
    return request.app.state.executor


#: Dependency alias for routes: ``compute: Compute`` then ``compute.run(fn, *args, cost_ms=...)``.
Compute = Annotated[BoundedExecutor, Depends(get_executor)]


def run_bounded(request: Request, fn: Callable[..., T], *args: Any, cost_ms: float | None = None,
                **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` under the app's time budget (see :meth:`BoundedExecutor.run`)."""
    return get_executor(request).run(fn, *args, cost_ms=cost_ms, **kwargs)
