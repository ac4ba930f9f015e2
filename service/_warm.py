"""Imported by the compute workers' forkserver (then :func:`touch` in each worker): fills per-process caches once.

The numerics' kernels are compiled by numba (optim.stability.kernels) on first use.  The exact rigid discretisation builds its series coefficients on first use
(models.discretize, cached per process) and scipy imports submodules lazily;
doing both here, before the forkserver forks any worker, makes every worker —
including one that replaces a killed worker — answer its first call at full speed.  The stiffness designs
build this process's CasADi solvers for the rigid and cable structures (cached per thread in
optim.stiffness.problem; the forked worker's main thread inherits them), ≈ 10-20 ms saved on a worker's first
design.
"""

import gc

from models.device import PRESETS, Device
from optim.stability.analysis import analyse_stability
from optim.stability.boundary import stability_boundary
from optim.stiffness import design_stiffness
from service.kernel_cache import compile_kernels_once

compile_kernels_once()   # the compiled loops (numba): compiled, or loaded from its cache, once

for _name in sorted(PRESETS):
    _device = Device(preset=_name)
    analyse_stability(_device, 1.0, 1e-6, "exact")
    analyse_stability(_device.rigid(), 1.0, 1e-6, "exact")
stability_boundary(Device(mass=1.0, damping=1.0), None, 3)
for _name in ("lhifam", "phantom-1.0"):
    design_stiffness(Device(preset=_name))
    design_stiffness(Device(preset=_name).rigid())

# everything so far lives as long as the forkserver and its forks: out of the collector's full passes (≈ 0.1 s over
# it otherwise, in whichever call triggers one), and its pages unwritten by them in the forked workers
gc.freeze()


def touch() -> None:
    """One stiffness design, run by each compute worker at warm-up (service.executor): milliseconds when the
    solvers were inherited from the forkserver, their construction otherwise — before readiness, not in the
    first request."""
    design_stiffness(Device(preset="lhifam"))
