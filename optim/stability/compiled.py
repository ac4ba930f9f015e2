"""How the numerics' kernels are compiled: numba's ``njit``, cached on disk where a cache directory is writable.

numba looks for a cache directory beside the source (``__pycache__``), then NUMBA_CACHE_DIR, then the user's cache
directory; where none is writable (a read-only install served by a user without a home) ``cache=True`` raises at
import, and the service would not start.  There each kernel is compiled without the disk cache instead: the same
machine code, only compiled again by every process that uses it (≈ 60 s of CPU for all of them, 2026-12-04, during the server's warm-up, before
/readyz says ready).  No fastmath anywhere: the kernels reproduce the Python they replace bit for bit.
"""

from __future__ import annotations

from typing import Callable, TypeVar, cast

from numba import njit

__all__ = ["kernel"]

F = TypeVar("F", bound=Callable)


def kernel(fn: F) -> F:
    """``njit(cache=True)(fn)``, or ``njit(fn)`` where no cache directory is writable."""
    try:
        return cast(F, njit(cache=True)(fn))    # a Dispatcher, called as fn is
    except RuntimeError:   # "cannot cache function …: no locator available for file …"
        return cast(F, njit(fn))
