"""Every compiled (numba) kernel of the numerics, compiled at once: optim.stability.rigid_kernel (the rigid fast
path's crossovers), optim.stability.rigid_tail (its proof that the tail holds none),
optim.stability.passivity_kernel (the delayed passivity bound), optim.stability.rendered_rigid (a rendered rigid
or cable wall's certified crossings), optim.stability.cable_kernel (the cable brackets), optim.workspace.normal_kernel
(the worst-normal search's inner loop), optim.workspace.normal_dual (its dual form) and optim.workspace.wall_kernel (the
wall plant's exact scan)."""

from optim.stability import cable_kernel, passivity_kernel, rendered_rigid, rigid_kernel, rigid_tail

__all__ = ["compile_kernels"]


def compile_kernels() -> None:
    """Compile every kernel now, or load it from numba's cache (≈ 1-2 s cached; compiling all of them
    costs ≈ 60 s of CPU, 2026-12-04: the service compiles them once per install, service.kernel_cache): a process
    that calls this before it serves answers its first analysis at full speed."""
    rigid_kernel.compile_kernels()
    rigid_tail.compile_kernels()
    passivity_kernel.compile_kernels()
    rendered_rigid.compile_kernels()
    cable_kernel.compile_kernels()
    from optim.workspace import normal_dual, normal_kernel, wall_kernel  # the workspace's loops and its exact scan

    normal_kernel.compile_kernels()
    normal_dual.compile_kernels()
    wall_kernel.compile_kernels()
