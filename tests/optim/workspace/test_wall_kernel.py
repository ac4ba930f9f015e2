"""The compiled wall scan (optim.workspace.wall_kernel) against its Python twin: every crossover and K_cr to 1e-12
relative on PHANToM poses and random arms, whole and fractional delays, B = 0 and B > 0 (with B_max)."""

from __future__ import annotations

import math

import numpy as np

from models.kinematics import KINEMATIC_PRESETS, load_kinematics
from optim.workspace.wall_plant import (
    WallModes,
    one_dof_critical_stiffness,
    one_dof_equivalent,
    wall_critical_stiffness,
    wall_modes,
)

from .arms import random_arm, random_normal


def _same(a, b, rel=1e-12):
    if math.isinf(a) or math.isinf(b) or a == 0.0 or b == 0.0:
        return a == b
    return abs(a / b - 1.0) <= rel


def _compare(modes: WallModes, t: float, td: float, b: float) -> None:
    got = wall_critical_stiffness(modes, t, td, b)
    ref = wall_critical_stiffness(modes, t, td, b, compiled=False)
    assert _same(got.critical_stiffness, ref.critical_stiffness), (got, ref)
    assert (got.frequency is None) == (ref.frequency is None)
    if got.frequency is not None:
        assert _same(got.frequency, ref.frequency)
    assert len(got.crossovers) == len(ref.crossovers)
    for (wa, ka), (wb, kb) in zip(got.crossovers, ref.crossovers):
        assert _same(wa, wb) and _same(ka, kb)
    assert got.reason == ref.reason or (got.reason and ref.reason and got.reason[:40] == ref.reason[:40])


def test_compiled_scan_is_the_python_scan():
    rng = np.random.default_rng(41)
    phantom = load_kinematics(**KINEMATIC_PRESETS["phantom-premium-1.5"])
    cases = 0
    while cases < 60:
        arm = phantom if cases % 3 == 0 else random_arm(rng)
        q = rng.uniform(arm.lower, arm.upper)
        mass, jac = arm.at(q)
        n = random_normal(rng, jac)
        modes = wall_modes(mass, jac, arm.joint_damping, n)
        if not modes.c:
            continue
        t = float(rng.uniform(2e-4, 2e-3))
        td = float(t * rng.choice([0.0, 1.0, 2.0, rng.uniform(0, 4)]))
        b = float(rng.choice([0.0, rng.uniform(0, 0.5)]))
        _compare(modes, t, td, b)
        _compare(one_dof_equivalent(modes), t, td, b)
        one = one_dof_critical_stiffness(modes, t, td, b)      # the rigid fast path at B = 0
        assert _same(one, wall_critical_stiffness(one_dof_equivalent(modes), t, td, b, compiled=False)
                     .critical_stiffness)
        cases += 1


def test_compiled_grid_is_the_scan_grid():
    """plain_scan_grid against crossovers.scan_grid (no hints): the same samples to 1 ulp (numpy's vectorised power
    and log10 may round apart), over θ_min from 1e-9 to 1e-2 and delays from 0 to 50 samples."""
    from optim.stability.crossovers import scan_grid
    from optim.workspace.wall_kernel import plain_scan_grid

    rng = np.random.default_rng(6)
    for _ in range(300):
        tm, d = 10 ** rng.uniform(-9, -2), float(rng.choice([0.0, 0.5, 1.0, rng.uniform(0, 50)]))
        a, b = scan_grid(tm, d, ()), plain_scan_grid(tm, d)
        assert a.shape == b.shape
        assert np.all(np.abs(a - b) <= 2.3e-16 * a)
