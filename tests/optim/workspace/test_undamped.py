"""Undamped joints in the workspace map: the wall's K_cr is 0 where the undamped modes outweigh the damping seen
along n (a ≤ τ·c₀ at B = 0), the worst normal finds it exactly, the MIMO loop (optim.workspace.mimo_loop: no modal
decomposition) agrees, and a damping too small to resolve is refused naming the field.

The independent checks: closed-loop eigenvalues of the full sampled N-DOF loop (stable below K_cr, unstable above;
unstable at every small K where K_cr = 0), scipy's eigh of (D, M) for the exact modes, and a dense sampling of the
sphere for the worst normal at B > 0."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from models.errors import InputError
from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from optim.stability.margins import NO_DAMPING_REASON
from optim.workspace.mimo_loop import closed_loop_matrix, unmoved, wall_spectral_radius
from optim.workspace.wall_plant import (
    UNDAMPED_REASON,
    pose_eig,
    undamped_unstable,
    wall_critical_stiffness,
    wall_modes,
)
from optim.workspace.workspace import workspace_map

T, TD = 1e-3, 5e-4


def _phantom(damping: list[float]):
    pre = dict(KINEMATIC_PRESETS["phantom-premium-1.5"])
    pre["joint_damping"] = damping
    return load_kinematics(**pre)


def _sphere(count: int) -> np.ndarray:
    k = np.arange(count) + 0.5
    t = np.arccos(1.0 - 2.0 * k / count)
    p = math.pi * (1.0 + 5.0 ** 0.5) * k
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)


def _margin(mass, jac, damping_q, n, sample_time, delay) -> float:
    """r = a/(τ c₀) − 1 along n, from scipy's eigh of the full pair (not pose_eig): λ below 1e-12·max is 0."""
    lam, vec = scipy.linalg.eigh(np.diag(damping_q), mass)
    c = (n @ jac @ vec) ** 2
    zero = lam < 1e-12 * lam.max()
    return float(np.sum(c[~zero] / lam[~zero]) / ((delay + 0.5 * sample_time) * np.sum(c[zero])) - 1.0)


def test_pose_eig_gives_exact_zeros_and_the_same_modes():
    rng = np.random.default_rng(11)
    for _ in range(100):
        n = int(rng.integers(1, 6))
        a = rng.normal(size=(n, n))
        mass = a @ a.T + 0.1 * np.eye(n)
        damping = rng.uniform(0.0, 1.0, n) * (rng.random(n) < 0.6)
        lam, vec = pose_eig(mass, damping)
        assert np.sum(lam == 0.0) == np.sum(damping == 0.0)          # exactly zero, not 1e-17
        assert np.all(lam[lam != 0.0] > 0.0)
        assert np.max(np.abs(vec.T @ mass @ vec - np.eye(n))) < 1e-10
        assert np.max(np.abs(np.diag(damping) @ vec - mass @ vec @ np.diag(lam))) < 1e-10
        ref = np.sort(scipy.linalg.eigh(np.diag(damping), mass, eigvals_only=True))
        assert np.allclose(np.sort(lam), ref, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("delay", [5e-4, 1.7e-3])
def test_the_rule_a_below_tau_c0_against_the_mimo_loop(delay):
    """Normals on both sides of a = τ·c₀ (r = ∓2 %, τ = t_d + T/2: the T/2 matters at this margin): K_cr = 0 and the
    MIMO loop unstable at small K below it; K_cr > 0 above it, the MIMO loop stable at K_cr·(1 − 1e-6) and unstable
    at K_cr·(1 + 1e-6)."""
    arm = _phantom([0.0, 0.0, 0.002])
    q = np.array([0.2, 0.3, 0.4])
    mass, jac = arm.at(q)
    # the normal of lowest r and one of high r; bisect the great circle between them for r = ∓0.02
    normals = _sphere(200)
    rs = np.array([_margin(mass, jac, arm.joint_damping, n, T, delay) for n in normals])
    lo, hi = normals[int(np.argmin(rs))], normals[int(np.argmax(rs))]

    def along(target: float) -> np.ndarray:
        a, b = 0.0, 1.0
        for _ in range(80):
            mid = 0.5 * (a + b)
            n = (1 - mid) * lo + mid * hi
            if _margin(mass, jac, arm.joint_damping, n / np.linalg.norm(n), T, delay) < target:
                a = mid
            else:
                b = mid
        n = (1 - a) * lo + a * hi
        return n / np.linalg.norm(n)

    below, above = along(-0.02), along(0.02)
    got = wall_critical_stiffness(wall_modes(mass, jac, arm.joint_damping, below), T, delay)
    assert got.critical_stiffness == 0.0 and got.reason == UNDAMPED_REASON
    for k in (1e-3, 1e-2, 0.1):
        assert wall_spectral_radius(mass, jac, arm.joint_damping, below, k, 0.0, T, delay) > 1.0 + 1e-12
    got = wall_critical_stiffness(wall_modes(mass, jac, arm.joint_damping, above), T, delay)
    assert 0.0 < got.critical_stiffness < math.inf and got.reason is None
    k = got.critical_stiffness
    assert wall_spectral_radius(mass, jac, arm.joint_damping, above, k * (1 - 1e-6), 0.0, T, delay) < 1.0
    assert wall_spectral_radius(mass, jac, arm.joint_damping, above, k * (1 + 1e-6), 0.0, T, delay) > 1.0


def test_the_worst_normal_of_an_undamped_device_is_exactly_zero():
    """PHANToM with joint damping (0, 0, 0.002): every pose has a normal of K_cr = 0 (the search used to answer
    1e-4 N/m); the MIMO loop along it is unstable at every small K."""
    arm = _phantom([0.0, 0.0, 0.002])
    rng = np.random.default_rng(4)
    poses = [rng.uniform(arm.lower, arm.upper) for _ in range(3)]
    result = workspace_map(arm, poses, "worst", T, TD)
    for q, p in zip(poses, result.points):
        # the normal sees no damping at all (NO_DAMPING_REASON) or too little beside an undamped mode
        assert p.critical_stiffness == 0.0 and p.reason in (UNDAMPED_REASON, NO_DAMPING_REASON)
        mass, jac = arm.at(q)
        n = np.array(p.normal)
        modes = wall_modes(mass, jac, arm.joint_damping, n)
        assert undamped_unstable(modes, T, TD) or all(li == 0.0 for li in modes.lam)
        for k in (1e-3, 1.0):
            assert wall_spectral_radius(mass, jac, arm.joint_damping, n, k, 0.0, T, TD) > 1.0 + 1e-12
    assert result.minimum_critical_stiffness == 0.0


def test_an_unseen_undamped_joint_leaves_the_loop_alone():
    """An undamped joint the wall does not move (nᵀJ e₁ = 0) keeps a z = 1 pole in the MIMO loop: it is left out
    (deflated), and the rest of the loop is stable below K_cr and unstable above."""
    arm = _phantom([0.0, 5e-4, 5e-4])
    q = np.array([0.3, 0.1, 0.5])
    mass, jac = arm.at(q)
    n = np.cross(jac[:, 0], jac[:, 1] + jac[:, 2])
    n /= np.linalg.norm(n)
    assert abs(n @ jac[:, 0]) < 1e-15
    basis = unmoved(jac, arm.joint_damping, n)
    assert basis.shape == (3, 1)
    got = wall_critical_stiffness(wall_modes(mass, jac, arm.joint_damping, n), T, TD)
    k = got.critical_stiffness
    assert 0.0 < k < math.inf
    raw = np.linalg.eigvals(closed_loop_matrix(mass, jac, arm.joint_damping, n, k * (1 - 1e-6), 0.0, T, TD))
    assert np.min(np.abs(raw - 1.0)) < 1e-12                   # the unmoved pole, at 1 up to rounding
    assert wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 - 1e-6), 0.0, T, TD) < 1.0
    assert wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 + 1e-6), 0.0, T, TD) > 1.0


@pytest.mark.parametrize("damping", [[1e-300, 1e-300, 1e-300], [1e-300, 0.0, 0.002], [1e-20, 5e-4, 5e-4]])
def test_damping_too_small_to_resolve_is_refused(damping):
    arm = _phantom(damping)
    with pytest.raises(InputError) as exc:
        workspace_map(arm, [np.array([0.1, 0.2, 0.3])], "worst", T, TD)
    assert exc.value.field == "device.kinematics.joint_damping"
    with pytest.raises(InputError):
        workspace_map(arm, [np.array([0.1, 0.2, 0.3])], [[0.0, 1.0, 0.0]], T, TD, 0.01)


@pytest.mark.slow
def test_undamped_phantom_against_dense_sampling_and_the_mimo_loop():
    """12 poses of the PHANToM with damping (0, 0, 0.002): at B = 0 every worst K_cr is 0 (the MIMO loop unstable
    at small K); at B = 0.02 N·s/m no normal of 400 sampled is lower than the worst found by 1e-9, and the MIMO loop
    changes stability across K_cr·(1 ± 1e-6) at it; random normals at B = 0 agree with the MIMO loop either way."""
    arm = _phantom([0.0, 0.0, 0.002])
    rng = np.random.default_rng(7)
    poses = [rng.uniform(arm.lower, arm.upper) for _ in range(12)]
    zero = workspace_map(arm, poses, "worst", T, TD)
    damped = workspace_map(arm, poses, "worst", T, TD, 0.02)
    dense = _sphere(400)
    for q, p0, p in zip(poses, zero.points, damped.points):
        mass, jac = arm.at(q)
        assert p0.critical_stiffness == 0.0
        assert wall_spectral_radius(mass, jac, arm.joint_damping, np.array(p0.normal), 1e-3, 0.0, T, TD) > 1.0
        ks = [wall_critical_stiffness(wall_modes(mass, jac, arm.joint_damping, n), T, TD, 0.02).critical_stiffness
              for n in dense]
        assert min(ks) >= p.critical_stiffness * (1 - 1e-9)
        n = np.array(p.normal)
        k = p.critical_stiffness
        assert wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 - 1e-6), 0.02, T, TD) < 1.0
        assert wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 + 1e-6), 0.02, T, TD) > 1.0
        for n in dense[rng.choice(len(dense), 3, replace=False)]:
            got = wall_critical_stiffness(wall_modes(mass, jac, arm.joint_damping, n), T, TD)
            k = got.critical_stiffness
            if k == 0.0:
                assert wall_spectral_radius(mass, jac, arm.joint_damping, n, 1e-3, 0.0, T, TD) > 1.0
            else:
                assert wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 - 1e-6), 0.0, T, TD) < 1.0
                assert wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 + 1e-6), 0.0, T, TD) > 1.0


def test_a_design_with_an_undamped_joint_is_decided_by_the_mimo_loop():
    """PHANToM with joint damping (0, 5e-4, 5e-4), 4 poses, verify: at B* the worst normals lie where the undamped
    joint is not seen; they are taken exactly there (not 1e-9 short of it, where the undamped pole sat 1e-16 from
    z = 1 and the MIMO check read "unstable" from rounding), so every worst case is stable by a clear margin."""
    from optim.workspace.analysis import PoseSpec
    from optim.workspace.design import workspace_design_job

    design, checks = workspace_design_job(None, "phantom-premium-1.5", None, None, [0.0, 5e-4, 5e-4],
                                          PoseSpec(lhs_samples=4, lhs_seed=3), "worst", T, TD, 1.0, None, None, 1,
                                          True)
    assert design.damping > 0.0 and design.stiffness > 0.0
    assert len(checks) == len(design.worst_cases) + 1           # every worst case, then the denser set's worst
    for c in checks:
        assert abs(c.spectral_radius - 1.0) > 1e-9, c          # decided, not a rounding-sized reading
    assert all(c.stable for c in checks[:len(design.worst_cases)])
