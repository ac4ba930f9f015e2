"""The OpenBLAS kernel (core type) numpy and scipy run on, read with threadpoolctl; CI (.ci/run) uses it to run the
numerics tests again under a kernel different from the machine's, so that no answer depends on the kernel.

    python scripts/blas_kernel.py           # the active kernel, e.g. SkylakeX (OPENBLAS_CORETYPE overrides it)
    python scripts/blas_kernel.py --other   # a kernel to compare with: Haswell, or Sandybridge on a Haswell machine

Both kernels named by --other run on any x86-64 CPU with AVX2 (Haswell) or AVX (Sandybridge), so forcing them never
asks the CPU for instructions it lacks.  Exit 1 when no OpenBLAS is loaded or numpy and scipy disagree.
"""

from __future__ import annotations

import sys

import numpy  # noqa: F401  (loads numpy's OpenBLAS)
import scipy.linalg  # noqa: F401  (and scipy's)
from threadpoolctl import threadpool_info


def active() -> str:
    kernels = {info.get("architecture") for info in threadpool_info() if info.get("internal_api") == "openblas"}
    if len(kernels) != 1 or None in kernels:
        sys.exit(f"blas_kernel: expected one OpenBLAS kernel, found {sorted(map(str, kernels))}")
    return kernels.pop()


def other(kernel: str) -> str:
    return "Sandybridge" if kernel.lower() == "haswell" else "Haswell"


if __name__ == "__main__":
    kernel = active()
    print(other(kernel) if sys.argv[1:] == ["--other"] else kernel)
