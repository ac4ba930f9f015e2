"""One CasADi solver per problem structure and per thread.

CasADi solver objects are not thread-safe (casadi #3456, #2929; MUMPS: Ipopt #733)
and building one costs far more than a solve (#3774), so each thread keeps its own,
built once per structure key and reused with new parameters.  Worker processes get
their own threads, hence their own solvers.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import TypeVar

__all__ = ["thread_solver"]

T = TypeVar("T")
_local = threading.local()


def thread_solver(namespace: str, key: Hashable, build: Callable[[], T]) -> T:
    """This thread's solver for ``(namespace, key)``, built by ``build()`` on first use."""
    cache = getattr(_local, "solvers", None)
    if cache is None:
        cache = _local.solvers = {}
    full = (namespace, key)
    if full not in cache:
        cache[full] = build()
    return cache[full]
