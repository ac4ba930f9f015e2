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


def test_lmax_where_the_top_two_eigenvalues_meet():
    """λ_max of symmetric 3 × 3s whose top two eigenvalues are 1e-14 to 1 apart (relative) against LAPACK's: to
    ~ε of the scale (the closed form alone lost ~√ε there, 1.2e-8)."""
    from optim.workspace.normal_dual import _lmax

    rng = np.random.default_rng(8)
    worst = 0.0
    for _ in range(300):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        top = rng.uniform(-1e5, 1e5)
        ev = np.array([top, top - 10 ** rng.uniform(-14, 0) * abs(top), top - rng.uniform(0.1, 2) * 1e5])
        a = q @ np.diag(ev) @ q.T
        a = 0.5 * (a + a.T)
        ref = float(np.linalg.eigvalsh(a)[2])
        got = _lmax(a[0, 0], a[0, 1], a[0, 2], a[1, 1], a[1, 2], a[2, 2])
        worst = max(worst, abs(got - ref) / np.max(np.abs(ev)))
    assert worst <= 1e-12


def test_phantom_poses_are_certified_and_a_birth_normal_sees_one_mode():
    """Every one of 30 PHANToM poses is certified (the dual's K equals the exact scan's at its normal to 1e-9; before
    the birth limit and the deflation a quarter were not).  Where the worst crossing is born (C semidefinite at θ*:
    μ* is NaN) the normal sees a single mode (orthogonal to the other two w_i), and its K_cr is that rigid mode's
    as the 1-DOF machinery computes it (mass 1/c, damping λ/c)."""
    import math

    import scipy.linalg

    from models.device import Device
    from optim.stability.margins import critical_stiffness

    phantom = load_kinematics(**KINEMATIC_PRESETS["phantom-premium-1.5"])
    births = 0
    for q in lhs_poses(phantom, 30, 3):
        mass, jac = phantom.at(q)
        got = dual_normal(mass, jac, phantom.joint_damping, 1e-3, 5e-4)
        assert got is not None
        n, predicted = got
        modes = wall_modes(mass, jac, phantom.joint_damping, n)
        assert abs(wall_critical_stiffness(modes, 1e-3, 5e-4).critical_stiffness / predicted - 1) <= 1e-9
        lam, vec = scipy.linalg.eigh(np.diag(phantom.joint_damping), mass)
        c = (n @ jac @ vec) ** 2
        if np.sum(c > 1e-20 * np.sum(c)) == 1:
            i = int(np.argmax(c))
            births += 1
            one = critical_stiffness(Device(mass=1 / c[i], damping=lam[i] / c[i], sample_time=1e-3, delay=5e-4), 0.0)
            assert math.isclose(one.critical_stiffness, predicted, rel_tol=1e-9)
    assert births >= 3
