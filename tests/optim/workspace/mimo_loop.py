"""The full N-DOF sampled wall loop the tests hold the SISO projection to: optim.workspace.mimo_loop (the joint-space
plant with three Cartesian force inputs, its exact ZOH with a fractional input delay from one augmented matrix
exponential, the Cartesian wall K·n·nᵀ + B·n·nᵀ(1 − z⁻¹)/T, the delay line as states; eigenvalues decide).  It shares
no code with the projection under test (optim.workspace.wall_plant: modal decomposition, RigidZOH, the crossover
scan), so it is an independent check of it; verify of the workspace design calls the same loop.  (A copy of it used to
live here; one implementation serves both.)
"""

from optim.workspace.mimo_loop import closed_loop_matrix, wall_spectral_radius

__all__ = ["closed_loop_matrix", "wall_spectral_radius"]
