"""Where a study's chunks run: a local process pool (default) or a Dask distributed cluster.

Both take a plain function and plain arguments (``service.studies.blocks.evaluate_block``,
``evaluate_planned``) and hand back futures; the coordinator waits on them and is the only one that
writes.  Workers build their own CasADi solvers: nothing symbolic crosses a process boundary (casadi #2949).
"""

from __future__ import annotations

import concurrent.futures as cf
import gc
import multiprocessing
import os
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Protocol

from ..lifeline import batch_worker_init

__all__ = ["Executor", "LocalExecutor", "DaskExecutor", "make_executor"]


class Executor(Protocol):
    kind: str
    #: the runner's largest chunk is multiplied by this: a task that costs more to schedule gets more points
    task_scale: int

    @property
    def slots(self) -> int: ...
    def submit(self, fn: Callable, *args: Any) -> Any: ...
    def share(self, obj: Any) -> Any: ...
    def wait(self, futures: set, timeout: float) -> tuple[set, set]: ...
    def cancel(self, futures: set) -> None: ...
    def reset(self) -> None: ...
    def close(self) -> None: ...


def study_worker_init(parent: int) -> None:
    """Initializer of the study pool's workers: die with the server, below its priority (batch_worker_init), and
    the numerics' compiled kernels loaded now (numba's cache, ≈ 0.2-0.5 s; compiled ≈ 3-10 s where no cache is
    written), when the pool starts, not inside the first chunk of a study (a cable grid's first chunk paid ≈ 9 s),
    and what they imported frozen out of the garbage collector's generations (gc.freeze)."""
    batch_worker_init(parent)
    from service.kernel_cache import compile_kernels_once

    compile_kernels_once()
    # The objects of the imports (numpy, scipy, pydantic, the models: ≈ 200k) out of the cyclic collector's reach: a
    # chunk of cable points allocates enough to run a few full collections, each of which walked all of them (issue
    # 32).  Nothing frozen is garbage: the modules live as long as the worker.
    gc.collect()
    gc.freeze()


class LocalExecutor:
    """A process pool sized to the cores (``spawn``: the server has threads, fork would copy their locks)."""

    kind = "local"
    task_scale = 1

    def __init__(self, workers: int | None = None):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self._pool: cf.ProcessPoolExecutor | None = None

    @property
    def slots(self) -> int:
        return self.workers

    def _get(self) -> cf.ProcessPoolExecutor:
        if self._pool is None:
            # A kill -9 of the server must not leave the pool's workers running (issue 18), and they yield the
            # cores to the server's requests (service.lifeline).
            self._pool = cf.ProcessPoolExecutor(max_workers=self.workers,
                                                mp_context=multiprocessing.get_context("spawn"),
                                                initializer=study_worker_init, initargs=(os.getpid(),))
        return self._pool

    def share(self, obj: Any) -> None:
        """None: a chunk's swept values go to a local worker with its task (a pipe; the plan would cost more)."""
        return None

    def submit(self, fn: Callable, *args: Any) -> cf.Future:
        try:
            return self._get().submit(fn, *args)
        except BrokenProcessPool:  # a worker died before the coordinator saw one of its futures fail
            self.reset()
            return self._get().submit(fn, *args)

    def wait(self, futures: set, timeout: float) -> tuple[set, set]:
        done, pending = cf.wait(futures, timeout=timeout, return_when=cf.FIRST_COMPLETED)
        return set(done), set(pending)

    def cancel(self, futures: set) -> None:
        for f in futures:
            f.cancel()

    def reset(self) -> None:
        """Drop a broken pool (a worker killed by the OS); the next submit starts a fresh one."""
        # Only a broken pool: every future of a broken pool fails, and each would call reset.
        if self._pool is not None and getattr(self._pool, "_broken", False):
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


class DaskExecutor:
    """Chunks become Dask tasks on the cluster at ``address`` (tasks compute and return, never write)."""

    kind = "dask"
    #: 4 × the local chunk (65,536 rigid points, ~0.2 s of work): a Dask task costs a few ms of scheduler, worker
    #: and client CPU whatever its size, on the cores the points need.  The worker evaluates it in parts of
    #: blocks.COLUMN_PART points (a whole 65,536-point rigid critical_stiffness chunk cost 13 % more per point).
    task_scale = 4

    def __init__(self, address: str, timeout: float = 30.0, direct: bool = True):
        from distributed import Client

        self.address = address
        # direct: results come from the workers to this client, not relayed through the scheduler (Dask's
        # default), which copied each block twice on a core the workers need; a worker this client cannot reach
        # is still gathered through the scheduler (distributed's fallback for missing keys)
        self.client = Client(address, set_as_default=False, timeout=timeout, direct_to_workers=direct)

    @property
    def slots(self) -> int:
        return max(1, sum(self.client.nthreads().values()))

    def share(self, obj: Any) -> Any:
        """``obj`` on every worker once (a future a task takes as an argument): a study's plan, from which a task
        makes its chunk's swept values itself instead of carrying them (1 MB a task, client → scheduler → worker,
        each hop a pickle on a core the workers need)."""
        return self.client.scatter(obj, broadcast=True, hash=False)

    def submit(self, fn: Callable, *args: Any) -> Any:
        # pure=False: the same chunk submitted again after a restart is a new task, not a cached key.
        return self.client.submit(fn, *args, pure=False)

    def wait(self, futures: set, timeout: float) -> tuple[set, set]:
        from distributed import wait

        try:
            with self.client.as_current():  # wait() looks up the default client; ours is not the default
                done, pending = wait(list(futures), timeout=timeout, return_when="FIRST_COMPLETED")
        except TimeoutError:
            return set(), set(futures)
        return set(done), set(pending)

    def cancel(self, futures: set) -> None:
        if futures:
            self.client.cancel(list(futures))

    def reset(self) -> None:
        pass  # the scheduler reschedules tasks of a lost worker itself

    def close(self) -> None:
        self.client.close()


def make_executor(dask_scheduler: str | None, workers: int | None, dask_direct: bool = True) -> Executor:
    return DaskExecutor(dask_scheduler, direct=dask_direct) if dask_scheduler else LocalExecutor(workers)
