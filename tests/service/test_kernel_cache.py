"""service.kernel_cache: the kernels are compiled by one process at a time (a fresh install's warm-up, forkserver and
study workers used to compile the same kernels side by side)."""

import fcntl
import subprocess
import sys
import time

import pytest

from service.kernel_cache import compile_kernels_once, lock_path

pytestmark = pytest.mark.slow


def test_a_second_process_waits_for_the_lock_then_loads():
    compile_kernels_once()                     # this process: the cache is written (or was)
    script = ("import time; from service.kernel_cache import compile_kernels_once as c; print('ready', flush=True); "
              "c(); print(repr(time.time()), flush=True)")
    with open(lock_path(), "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)         # as a process compiling now would hold it
        proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "ready"    # its imports are over
        time.sleep(4.0)                        # loading the cache takes ≈ 1-2 s: unlocked, it would be done by now
        released = time.time()
        fcntl.flock(fh, fcntl.LOCK_UN)
    finished = float(proc.stdout.readline())
    assert proc.wait(timeout=120) == 0
    assert finished > released, "compile_kernels_once did not wait for the lock"


def test_the_lock_file_is_per_source_tree():
    path = lock_path()
    assert path.name.startswith("zwidth-kernels-") and path.suffix == ".lock"
    assert lock_path() == path
