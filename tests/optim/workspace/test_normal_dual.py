"""The worst normal by duality (B = 0, rank 3) against the sphere search it short-cuts, and its certificate."""

from __future__ import annotations

import numpy as np

from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from optim.workspace.normal_search import dual_normal, worst_normal
from optim.workspace.wall_plant import wall_critical_stiffness, wall_modes
from optim.workspace.workspace import lhs_poses

from .arms import random_arm


def _k(arm, mass, jac, n, t, td):
    return wall_critical_stiffness(wall_modes(mass, jac, arm.joint_damping, n), t, td).critical_stiffness


def test_dual_normal_matches_the_sphere_search():
    """PHANToM poses and random 3-DOF arms: wherever the exact scan certifies the dual's prediction (to 1e-9, the
    rule workspace_map applies), its K_cr equals the sphere search's to 1e-9 (neither may be lower: each is a min);
    at least half are certified."""
    rng = np.random.default_rng(33)
    phantom = load_kinematics(**KINEMATIC_PRESETS["phantom-premium-1.5"])
    cases = [(phantom, q, 1e-3, 5e-4) for q in lhs_poses(phantom, 8, 7)]
    while len(cases) < 14:
        arm = random_arm(rng)
        if arm.dof == 3:
            t = float(rng.uniform(2e-4, 2e-3))
            cases.append((arm, rng.uniform(arm.lower, arm.upper), t, float(t * rng.uniform(0, 3))))
    certified = 0
    for arm, q, t, td in cases:
        mass, jac = arm.at(q)
        got = dual_normal(mass, jac, arm.joint_damping, t, td)
        if got is None:                                    # no trusted dual value: the search decides
            continue
        n, predicted = got
        k_dual = _k(arm, mass, jac, n, t, td)
        assert k_dual >= predicted * (1 - 1e-9)    # lower: a crossing at another θ that the dual θ search missed
        if abs(k_dual / predicted - 1) > 1e-9:
            continue
        certified += 1
        k_search = _k(arm, mass, jac, worst_normal(mass, jac, arm.joint_damping, 3, t, td, 0.0), t, td)
        assert abs(k_dual / k_search - 1) <= 1e-9
    assert certified >= len(cases) // 2
