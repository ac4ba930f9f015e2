"""The numerics' compiled kernels, compiled by one process of this machine at a time.

A fresh install has no numba cache: compiling every kernel costs ≈ 60 s of CPU (measured 2026-12-04 on a 2-core AMD
EPYC: cable_kernel 26 s, rendered_rigid 15 s, the workspace's 11 s, the rest 9 s).  The server's warm-up, the compute
workers' forkserver and each study worker all compile at start; side by side they compiled the same kernels three or
four times over on two cores, and the first design request on a cold install waited ≈ 220 s (load ≈ 6) — past the
request budget, a 503.  Here the first process to arrive compiles and writes numba's cache while the others wait on
a file lock, then load the cache (≈ 1-2 s).  A process that dies holding the lock releases it (flock); a waiting
process then compiles what is still missing itself.
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path

from optim.stability.kernels import compile_kernels

__all__ = ["compile_kernels_once", "lock_path"]


def lock_path() -> Path:
    """One lock file per installed source tree (a second checkout compiles its own kernels beside it)."""
    import optim

    source = str(Path(optim.__file__).resolve().parent)
    digest = hashlib.sha256(source.encode()).hexdigest()[:16]
    return Path(tempfile.gettempdir()) / f"zwidth-kernels-{digest}.lock"


def compile_kernels_once() -> None:
    """:func:`optim.stability.kernels.compile_kernels` under a machine-wide lock (unlocked where no lock file can be
    opened, e.g. a read-only temporary directory or another user's lock file, or where the platform has no flock)."""
    try:
        import fcntl
        fh = open(lock_path(), "a")
    except (ImportError, OSError):
        compile_kernels()
        return
    with fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX)
        except OSError:
            pass
        try:
            compile_kernels()
        finally:
            try:
                fcntl.flock(fh, fcntl.LOCK_UN)
            except OSError:
                pass
