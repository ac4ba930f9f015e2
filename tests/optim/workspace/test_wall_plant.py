"""The wall plant's exact K_cr against the full N-DOF sampled closed loop (tests/optim/workspace/mimo_loop.py: no
modal decomposition, no RigidZOH, no scan) and against the 1-DOF machinery on one-mode plants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.margins import critical_stiffness
from optim.workspace.wall_plant import WallModes, wall_critical_stiffness, wall_modes

from .arms import random_arm, random_normal
from .mimo_loop import wall_spectral_radius

EPS = 1e-6


@pytest.mark.parametrize(("m", "b", "t", "td", "B"), [
    (5.4, 3.5, 1e-3, 0.0, 0.0), (5.4, 3.5, 1e-3, 1e-3, 20.0), (0.2, 0.01, 1e-3, 2.5e-3, 5.0),
    (1.0, 1e-6, 1e-4, 3.3e-4, 0.0), (0.05, 0.3, 5e-4, 7.7e-4, 0.0)])
def test_one_mode_is_the_rigid_device(m, b, t, td, B):
    ref = critical_stiffness(Device(mass=m, damping=b, sample_time=t, delay=td), B).critical_stiffness
    got = wall_critical_stiffness(WallModes((1 / m,), (b / m,)), t, td, B).critical_stiffness
    assert got == pytest.approx(ref, rel=1e-12, abs=0)


def _cases(count: int, seed: int):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        arm = random_arm(rng)
        q = rng.uniform(arm.lower, arm.upper)
        mass, jac = arm.at(q)
        n = random_normal(rng, jac)
        modes = wall_modes(mass, jac, arm.joint_damping, n)
        if not modes.c:
            continue
        t = float(rng.uniform(1e-4, 2e-3))
        td = float(t * rng.choice([0.0, rng.uniform(0, 5)]))
        b_virt = float(rng.choice([0.0, rng.uniform(0, 2.0)]))
        out.append((arm, mass, jac, n, modes, t, td, b_virt))
    return out


def _check(cases) -> tuple[int, int, list]:
    confirmed = infinite = 0
    bad = []
    for arm, mass, jac, n, modes, t, td, b_virt in cases:
        res = wall_critical_stiffness(modes, t, td, b_virt)
        k = res.critical_stiffness
        if not math.isfinite(k):
            infinite += 1
            continue
        if k == 0.0:   # "no stable K": the closed loop at small and large K says so
            for kk in (1e-6, 1.0, 1e3):
                if wall_spectral_radius(mass, jac, arm.joint_damping, n, kk, b_virt, t, td) < 1.0 - 1e-12:
                    bad.append(("stable at", kk, res.reason))
            confirmed += 1
            continue
        below = wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 - EPS), b_virt, t, td)
        above = wall_spectral_radius(mass, jac, arm.joint_damping, n, k * (1 + EPS), b_virt, t, td)
        if below < 1.0 and above > 1.0:
            confirmed += 1
        else:
            bad.append((k, below - 1, above - 1, t, td, b_virt, n))
    return confirmed, infinite, bad


def test_kcr_is_the_mimo_loops_boundary_fast():
    confirmed, _, bad = _check(_cases(40, 3))
    assert not bad, bad
    assert confirmed >= 35


@pytest.mark.slow
def test_kcr_is_the_mimo_loops_boundary_500():
    confirmed, _, bad = _check(_cases(500, 11))
    assert not bad, bad
    assert confirmed >= 490


def test_kcr_is_the_mimo_loops_boundary_on_the_phantom_preset():
    """The PHANToM preset (its joint coupling, its damping at the motor axes): random poses, normals, delays, B."""
    from models.kinematics import KINEMATIC_PRESETS, load_kinematics

    arm = load_kinematics(**KINEMATIC_PRESETS["phantom-premium-1.5"])
    rng = np.random.default_rng(17)
    cases = []
    for _ in range(12):
        q = rng.uniform(arm.lower, arm.upper)
        mass, jac = arm.at(q)
        n = random_normal(rng, jac)
        t = float(rng.uniform(2e-4, 2e-3))
        cases.append((arm, mass, jac, n, wall_modes(mass, jac, arm.joint_damping, n), t,
                      float(t * rng.choice([0.0, rng.uniform(0, 3)])), float(rng.choice([0.0, rng.uniform(0, 0.5)]))))
    confirmed, _, bad = _check(cases)
    assert not bad, bad
    assert confirmed == 12
