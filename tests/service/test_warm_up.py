"""The server's warm-up (service.app._warm_up, run before /readyz says ready): this process's compiled kernels, then
everything alive frozen out of the garbage collector's full passes, then the compute workers."""

import gc

from optim.stability import passivity_kernel, rigid_kernel, rigid_tail
from service.app import _warm_up


class _Pool:
    """Records that the compute workers were warmed, and what the collector held frozen by then."""

    frozen_at_warm_up = None

    def warm_up(self) -> bool:
        self.frozen_at_warm_up = gc.get_freeze_count()
        return True


def test_warm_up_compiles_the_kernels_and_freezes_before_the_workers():
    pool = _Pool()
    try:
        _warm_up(pool)
        assert pool.frozen_at_warm_up and pool.frozen_at_warm_up > 10_000
    finally:
        gc.unfreeze()
    for kernel in (rigid_kernel.binding_root, rigid_kernel.level_roots, rigid_kernel.k_eq, rigid_tail._tail_is_clear,
                   passivity_kernel.prefix_samples, passivity_kernel.polish_max, passivity_kernel.best_of_rows):
        assert kernel.signatures, kernel   # compiled (or loaded from numba's cache), not left to the first request
