"""The compiled worst-normal inner loop against its Python twin (optim.workspace.normal_search._PoseLoop)."""

from __future__ import annotations

import numpy as np

from optim.workspace.normal_search import _PoseLoop

from .arms import random_arm


def test_kernel_matches_python_twin():
    rng = np.random.default_rng(21)
    worst, compared = 0.0, 0
    for _ in range(12):
        arm = random_arm(rng)
        mass, jac = arm.at(rng.uniform(arm.lower, arm.upper))
        t = float(rng.uniform(2e-4, 2e-3))
        loop = _PoseLoop(mass, jac, arm.joint_damping, t, float(t * rng.choice([0.0, 1.0, rng.uniform(0, 4)])),
                         float(rng.choice([0.0, rng.uniform(0, 0.5)])))
        normals = rng.normal(size=(60, 3))
        normals /= np.linalg.norm(normals, axis=1)[:, None]
        g = len(loop.grid)
        lo = int(rng.integers(0, g - 10))
        for window in (None, (lo, lo + 10), (g - 8, g)):
            got = loop.critical(normals, window)
            ref = loop.critical_python(normals, window)
            assert np.array_equal(np.isinf(got), np.isinf(ref))
            fin = np.isfinite(ref)
            if np.any(fin):
                worst = max(worst, float(np.max(np.abs(got[fin] / ref[fin] - 1.0))))
                compared += int(np.sum(fin))
    assert compared > 500
    assert worst <= 1e-12
