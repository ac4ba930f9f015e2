"""The compute worker process of service.executor: its loop, and the parent's handle on it.

A worker is one process forked from the multiprocessing forkserver; it serves one call at a time over a
pipe and dies with the forkserver, which dies with the server (service.lifeline).
"""

from __future__ import annotations

from multiprocessing.connection import Connection
from typing import Any, Callable, TypeVar

__all__ = ["Worker", "warm_worker"]

T = TypeVar("T")


def _serve(conn: Connection) -> None:
    """Worker loop: say "ready", then receive (fn, args, kwargs), send back ("ok", value) or ("err", exception)."""
    from .lifeline import die_with_parent, lower_priority

    # The parent is the forkserver: single-threaded, it dies with the server (service.lifeline).
    die_with_parent(pdeathsig=True)
    lower_priority()
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


def warm_worker() -> None:
    """Run in each worker at warm-up: the numerics' caches are filled (inherited from the forkserver's
    import of service._warm, else built now), so the first request after readiness pays nothing."""
    from . import _warm

    _warm.touch()


class Worker:
    def __init__(self, ctx: Any) -> None:
        parent, child = ctx.Pipe()
        self.process = ctx.Process(target=_serve, args=(child,), name="zwidth-compute", daemon=True)
        self.process.start()
        child.close()
        self.conn: Connection = parent
        self.ready = False

    def wait_ready(self, timeout: float) -> None:
        """Wait for the worker's greeting (TimeoutError, EOFError if it died)."""
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
