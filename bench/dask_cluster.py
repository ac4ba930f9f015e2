"""A throw-away Dask cluster on loopback (a scheduler and N single-thread workers as processes).

Used by the study benchmark and tests; every process is killed on exit, whatever happened.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from bench.live_server import ROOT, free_port
from service.lifeline import WORKER_NICE

__all__ = ["local_dask_cluster"]


def _kill(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(10)
        except (subprocess.TimeoutExpired, ProcessLookupError):
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait(10)


@contextmanager
def local_dask_cluster(workers: int = 2, timeout: float = 60.0) -> Iterator[str]:
    """Yield the scheduler address of ``dask scheduler`` + ``workers`` × ``dask worker --nthreads 1``."""
    dask = str(Path(sys.executable).parent / "dask")
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
           # the workers' statistical profiler samples the task thread's stack every 10 ms (for the dashboard, which
           # is off): ~5 % of a worker's CPU on a study's vectorised chunks (4.25 → 4.06 CPU-s per 1M points)
           "DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False"}
    log = tempfile.TemporaryFile()
    scratch = tempfile.TemporaryDirectory(prefix="zwidth-dask-")
    procs: list[subprocess.Popen] = []
    common = dict(cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        try:
            _start(procs, dask, port, address, workers, scratch.name, common, timeout)
        except Exception:
            log.seek(0)
            sys.stderr.write(log.read().decode(errors="replace")[-4000:])
            raise
        yield address
    finally:
        for p in reversed(procs):
            _kill(p)
        log.close()
        scratch.cleanup()


#: Runs a command with PR_SET_PDEATHSIG = SIGKILL armed (a dask worker given SIGTERM tried to close gracefully
#: towards its dead scheduler and stayed) (kept across exec): the cluster goes when the process that
#: started it goes, even by SIGKILL or `timeout`, where no ``finally`` runs (a killed test run left 15 scheduler and
#: worker processes behind, ~2 % of a core each, for an hour).  The parent's pid is checked after arming: it may
#: have died in between.
_DIE_WITH_PARENT = ("import ctypes, os, signal, sys; ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL); "
                    "os.getppid() == int(sys.argv[1]) or sys.exit(1); os.execvp(sys.argv[2], sys.argv[2:])")


def _launch(cmd: list[str]) -> list[str]:
    if not sys.platform.startswith("linux"):
        return cmd
    return [sys.executable, "-c", _DIE_WITH_PARENT, str(os.getpid()), *cmd]


def _start(procs, dask, port, address, workers, scratch, common, timeout) -> None:
    from distributed import Client

    procs.append(subprocess.Popen(_launch([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                           "--no-dashboard"]), **common))
    for _ in range(workers):
        # One thread per process: CasADi solvers are not thread-safe (FIELD-NOTES).
        # at the niceness the service gives its own pool's workers (service.lifeline.lower_priority): the service
        # and the scheduler come first, and on a shared machine both executors compete for the cores alike
        procs.append(subprocess.Popen(_launch(["nice", "-n", str(WORKER_NICE), dask, "worker", address,
                                               "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                                               "--no-dashboard", "--local-directory", scratch]), **common))
    with Client(address, timeout=timeout, set_as_default=False) as client:
        client.wait_for_workers(workers, timeout=timeout)
