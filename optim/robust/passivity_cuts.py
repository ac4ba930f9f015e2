"""The passivity cuts of the robust stiffness design: the box's passivity corners and the angles found so far.

A cut (corner, θ) is a valid constraint for every B and K, so the cuts are kept across the scenario rounds of
optim.robust.stiffness; the exchange adds the most violated angle of every corner a solution is not passive on
(cutting planes, as optim.stiffness.design).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optim.robust.passivity import PassivityCorner
from optim.stability.passivity import kernel, largest_passive_stiffness, passive_alpha_on_grid, passivity_margin

__all__ = ["PassivityCuts", "PASSIVITY_RTOL"]

PASSIVITY_RTOL = 1e-7        # as optim.stiffness.design: stop the cuts here, then clip K to the exact bound


@dataclass
class PassivityCuts:
    """The box's passivity corners and the cuts (corner index, θ) the exchange has found."""

    corners: list[PassivityCorner]
    cuts: list[tuple[int, float]] = field(default_factory=list)

    def add(self, i: int, theta: float) -> bool:
        if any(j == i and abs(theta - t) <= 1e-12 for j, t in self.cuts):
            return False
        self.cuts.append((i, float(theta)))
        return True

    def rows(self, k_ref: float, b_ref: float) -> np.ndarray:
        """The cuts as (u, v, w) rows of problem.py: K·T·s/2 − B·c ≤ b over b, in k = K/K_ref, b = B/B_ref."""
        rows = []
        for i, theta in self.cuts:
            c = self.corners[i]
            s, cos = kernel(np.array([theta]), c.delay_samples)
            rows.append((k_ref * c.sample_time * s[0] / (2 * c.damping), b_ref * cos[0] / c.damping, 1.0))
        return np.array(rows, float).reshape(-1, 3)

    def coarse(self, bgrid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """On the B grid, per corner (rows): passive K [N/m] and the angle that binds (a seed on
        optim.stability.passivity's θ grid); and per B the corner with the smallest."""
        ks, thetas = [], []
        for c in self.corners:
            # Table 1 with m = 1 (passivity does not depend on the mass): δ = bT, β = BT, K = α/T²
            alpha, theta = passive_alpha_on_grid(c.damping * c.sample_time, c.delay_samples, bgrid * c.sample_time)
            ks.append(alpha / c.sample_time ** 2)
            thetas.append(theta)
        return np.array(ks), np.array(thetas), np.argmin(np.array(ks), axis=0)

    def exchange(self, k: float, b: float) -> bool:
        """Add the most violated angle of every corner on which (K, B) is not passive; True if any was added."""
        changed = False
        for i, c in enumerate(self.corners):
            if k > largest_passive_stiffness(c.device, b).stiffness * (1 + PASSIVITY_RTOL):
                check = passivity_margin(c.device, k, b)
                if check.worst_angle is not None:
                    changed |= self.add(i, check.worst_angle)
        return changed
