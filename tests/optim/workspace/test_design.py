"""The workspace design: one (K, B) stable at every design pose and normal, its label held to the full MIMO loop.

At every worst case of the exchange the MIMO closed loop (tests/optim/workspace/mimo_loop.py, no modal
decomposition) is stable at the design's (K, B); at the binding worst case it is unstable at K/g·(1 + 1e-6); and the
denser set's worst point agrees with the label: stable at (K, B) when ``verified``, unstable when ``unverified``.
"""

from __future__ import annotations

import numpy as np

from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from optim.workspace.design import design_workspace_stiffness
from optim.workspace.workspace import lhs_poses, workspace_map

from .mimo_loop import wall_spectral_radius

T, TD = 1e-3, 1e-3


def _rho(arm, pose, normal, k, b):
    mass, jac = arm.at(np.asarray(pose))
    return wall_spectral_radius(mass, jac, arm.joint_damping, np.asarray(normal), k, b, T, TD)


def test_workspace_design_against_the_mimo_loop():
    arm = load_kinematics(**KINEMATIC_PRESETS["planar-2link"])
    poses = lhs_poses(arm, 6, 3)
    d = design_workspace_stiffness(arm, poses, "worst", T, TD, min_gain_margin_db=1.0, verify_factor=2)
    assert d.status in ("verified", "unverified") and d.stiffness and d.damping is not None
    assert d.gain == 10 ** (-1 / 20)
    # every design pose's worst normal at B has K_cr ≥ K/g (the design's own claim)
    at_b = workspace_map(arm, poses, "worst", T, TD, d.damping)
    assert at_b.minimum_critical_stiffness >= d.stiffness / d.gain * (1 - 1e-9)
    binding = min(d.worst_cases, key=lambda c: c.critical_stiffness)
    assert abs(binding.critical_stiffness * d.gain / d.stiffness - 1) < 1e-9
    for case in d.worst_cases:
        assert _rho(arm, case.pose, case.normal, d.stiffness, d.damping) < 1.0
    assert _rho(arm, binding.pose, binding.normal, d.stiffness / d.gain * (1 + 1e-6), d.damping) > 1.0
    vw = d.verification_worst
    assert vw is not None and d.verification_margin is not None
    assert d.verification_margin == vw.critical_stiffness / d.stiffness - 1
    rho = _rho(arm, vw.pose, vw.normal, d.stiffness, d.damping)
    assert (rho < 1.0) if d.status == "verified" else (rho > 1.0)
    assert "gravity" in d.note
