"""Multi-DOF devices: the wall plant along a normal at a pose, and the workspace map of K_cr."""
