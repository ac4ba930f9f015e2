"""The "worst" normal is the worst: a dense sampling of the unit sphere finds no normal with a lower K_cr."""

from __future__ import annotations

import math

import numpy as np
import pytest

from optim.workspace.wall_plant import wall_critical_stiffness, wall_modes
from optim.workspace.workspace import workspace_map

from .arms import random_arm


def _sphere(count: int) -> np.ndarray:
    k = np.arange(count) + 0.5
    t = np.arccos(1.0 - 2.0 * k / count)
    p = math.pi * (1.0 + 5.0 ** 0.5) * k
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)


def _check(cases: int, dense: int, seed: int) -> list:
    rng = np.random.default_rng(seed)
    bad = []
    for _ in range(cases):
        arm = random_arm(rng)
        q = rng.uniform(arm.lower, arm.upper)
        t = float(rng.uniform(2e-4, 2e-3))
        td = float(t * rng.uniform(0, 3))
        b_virt = float(rng.choice([0.0, rng.uniform(0, 0.5)]))
        got = workspace_map(arm, [q], "worst", t, td, b_virt).minimum_critical_stiffness
        mass, jac = arm.at(q)
        normals = _sphere(dense)
        if np.linalg.matrix_rank(jac, tol=1e-9) < 3:      # planar: the plane's circle, densely, and the sphere
            u, _, _ = np.linalg.svd(jac)
            phi = np.linspace(0, math.pi, dense, endpoint=False)
            normals = np.concatenate([normals, (u[:, :2] @ np.stack([np.cos(phi), np.sin(phi)])).T])
        for n in normals:
            modes = wall_modes(mass, jac, arm.joint_damping, n)
            if not modes.c:
                continue
            k = wall_critical_stiffness(modes, t, td, b_virt).critical_stiffness
            if k < got * (1 - 1e-9):
                bad.append((k, got, n))
                break
    return bad


def test_worst_normal_fast():
    assert not _check(3, 200, 5)


@pytest.mark.slow
def test_worst_normal_dense():
    assert not _check(4, 500, 9)


def test_worst_normal_phantom_premium():
    """The PHANToM preset (3 DOF, its own damping): the worst normal against 400 sphere normals at 3 poses."""
    from models.kinematics import KINEMATIC_PRESETS, load_kinematics

    arm = load_kinematics(**KINEMATIC_PRESETS["phantom-premium-1.5"])
    rng = np.random.default_rng(3)
    for b_virt in (0.0, 0.02):
        q = rng.uniform(arm.lower, arm.upper)
        got = workspace_map(arm, [q], "worst", 1e-3, 5e-4, b_virt).minimum_critical_stiffness
        mass, jac = arm.at(q)
        ks = [wall_critical_stiffness(wall_modes(mass, jac, arm.joint_damping, n), 1e-3, 5e-4, b_virt)
              .critical_stiffness for n in _sphere(400)]
        assert min(ks) >= got * (1 - 1e-9)
        assert min(ks) <= got * 1.05      # the sampling comes close: the answer is a minimum, not an outlier
