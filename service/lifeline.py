"""Child processes die with their parent: no orphaned worker after a ``kill -9`` of the server.

A ``kill -9`` runs no shutdown code, so a worker must notice by itself that its parent is gone.  Two
mechanisms, because each has a gap:

* ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` (Linux): the kernel kills the child when its parent *thread*
  ends — even a thread that ends normally.  It is therefore only armed where the parent is
  single-threaded for its whole life (``pdeathsig=True``: a worker forked by the multiprocessing
  forkserver, whose only thread is its main loop).  It also works while the child is busy in C code
  that holds the GIL.
* a watchdog thread that exits the process (``os._exit``) as soon as ``os.getppid()`` differs from the
  parent it started with (the child was re-parented to init or a subreaper).  Portable and thread-safe
  for any parent; it needs the GIL, so a long C call delays it to the call's end.

The forkserver itself exits when the server dies (it reads EOF on its "alive" pipe); the
multiprocessing resource tracker exits once every process holding its pipe (server, forkserver and
workers) has gone.  So the whole session goes with the server.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import threading

__all__ = ["die_with_parent", "lower_priority", "batch_worker_init", "WATCH_INTERVAL", "WORKER_NICE"]

#: Niceness added to the compute and study workers: on a machine with as many cores as workers, busy workers
#: at the server's priority took the cores from the server's event loop and inline analyses (a cheap analysis
#: p99 of 2 s under 64 clients); at nice 10 the kernel gives the server ~10× their share when both want a core.
WORKER_NICE = 10
#: How often the watchdog looks at the parent's pid [s].
WATCH_INTERVAL = 0.25
_PR_SET_PDEATHSIG = 1


def _arm_pdeathsig() -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch(parent: int) -> None:
    stop = threading.Event()
    while not stop.wait(WATCH_INTERVAL):
        if os.getppid() != parent:
            os._exit(1)


def die_with_parent(pdeathsig: bool = False, parent: int | None = None) -> None:
    """Make this process exit when its parent (``parent``, default the current one) dies.

    ``parent`` should be read as early as possible in the child: if the parent died before this call,
    the child was already re-parented and the watchdog sees the difference at once.
    """
    parent = os.getppid() if parent is None else parent
    if pdeathsig and _arm_pdeathsig() and os.getppid() != parent:
        os._exit(1)   # the parent died before the signal was armed
    threading.Thread(target=_watch, args=(parent,), name="zwidth-lifeline", daemon=True).start()


def lower_priority(increment: int = WORKER_NICE) -> None:
    """Run this (worker) process below the server's priority: batch numerics yield to requests."""
    try:
        os.nice(increment)
    except OSError:
        pass


def batch_worker_init(parent: int) -> None:
    """Initializer of the study pool's workers: die with the server (watchdog: the spawning thread may end
    before the pool), below its priority."""
    die_with_parent(pdeathsig=False, parent=parent)
    lower_priority()
