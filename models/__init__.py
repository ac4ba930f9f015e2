"""zwidth physics: devices, plants, exact sampled-data discretisation."""

import os as _os

import numpy as _np  # noqa: F401  (load both BLAS libraries before limiting them)
import scipy.linalg as _sla  # noqa: F401
from threadpoolctl import threadpool_limits as _threadpool_limits

# The numerics work on tiny matrices (≤ 8×8), where a BLAS thread pool costs far
# more than it saves: measured here, one 8×8 expm took 8 ms with OpenBLAS's
# default pool (the other core busy) and 0.014 ms single-threaded.  threadpoolctl
# applies the limit even when numpy was imported first; an explicit
# OPENBLAS_NUM_THREADS / OMP_NUM_THREADS from the user wins.
if not any(_os.environ.get(v) for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")):
    _threadpool_limits(limits=1, user_api="blas")
