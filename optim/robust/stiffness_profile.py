"""The scenarios of the robust stiffness design and their coarse robust profile min_s g·K_cr(B; s) over B.

Each scenario is a device of the box with its boundary curve (optim.stiffness.profile) sampled up to the
current B bound; the profile is the smallest of every scenario's g·K_cr(B) (and every passivity corner's
passive K, and the caps) on one physical B grid, whose best point seeds the NLP (stiffness_seeding.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from models.device import Device
from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox
from optim.robust.passivity_cuts import PassivityCuts
from optim.stability.margins import max_stable_damping
from optim.stiffness.profile import BoundaryCurve, boundary_curve, coarse_critical

__all__ = ["Scenario", "scenario_at", "initial_points", "RobustProfile", "coarse_profile"]


@dataclass
class Scenario:
    """One device of the box and what the exchange tracks on it (mutated as the rounds learn)."""

    point: np.ndarray
    device: Device
    b_max: float
    """the device's largest stable virtual damping [N·s/m]."""
    curve: BoundaryCurve | None = None
    crossings: list = field(default_factory=list)     # [(θ, (lo, hi))]
    nyquist: bool = False
    beta_hi: float | None = None                      # the β range the curve was sampled for


def scenario_at(box: UncertaintyBox, point: np.ndarray) -> Scenario:
    dev = box.device_at(point)
    return Scenario(point, dev, max_stable_damping(dev))


def initial_points(box: UncertaintyBox) -> np.ndarray:
    """The nominal device (clipped into the box) and every corner of the paths that enter the stiffness loop."""
    base = box.nominal_point()
    active = box.relevant(STIFFNESS_PATHS)
    pts = [base]
    for c in box.corners():
        p = base.copy()
        p[active] = c[active]
        pts.append(p)
    return np.unique(np.array(pts), axis=0)


@dataclass(frozen=True)
class RobustProfile:
    """The coarse robust profile, or why no positive stiffness exists."""

    status: Literal["found", "infeasible"]
    damping: float = 0.0
    """B₀ [N·s/m]: the grid's best B."""
    stiffness: float = 0.0
    """K₀ [N/m]: the profile there."""
    index: int = 0
    """B₀'s index on the grid (for the passivity seeds)."""
    passive: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    """with passivity: PassivityCuts.coarse on the grid (passive K per corner, binding angle, smallest corner)."""
    reason: str | None = None


def _sample_curves(scenarios: list[Scenario], upper_b: float) -> None:
    for sc in scenarios:
        beta_hi = upper_b / sc.device.damping_scale
        if sc.curve is None or sc.beta_hi != beta_hi:
            sc.curve = boundary_curve(sc.device, beta_hi)
            sc.beta_hi = beta_hi


def coarse_profile(scenarios: list[Scenario], g: float, upper_b: float, k_cap: float,
                   passivity: PassivityCuts | None) -> RobustProfile:
    """min over scenarios of g·K_cr(B) (and over passivity corners of the passive K, and K's caps) on one
    physical B grid in [0, upper_b), and its largest point."""
    _sample_curves(scenarios, upper_b)
    bgrid = np.unique(np.concatenate([np.linspace(0.0, upper_b, 241)[:-1],
                                      upper_b * (1 - np.geomspace(1e-6, 1e-2, 5)),
                                      # a passive wall needs B of the order of b, often ≪ B_max: a log part too
                                      upper_b * np.geomspace(1e-7, 1e-2, 81 if passivity is not None else 0),
                                      *[np.array(sc.curve.breakpoints) * sc.device.damping_scale for sc in scenarios]]))
    bgrid = bgrid[(bgrid >= 0) & (bgrid < upper_b)]
    obj = np.full(bgrid.shape, np.inf)
    for sc in scenarios:
        obj = np.minimum(obj, g * coarse_critical(sc.curve, bgrid / sc.device.damping_scale)
                         * sc.device.stiffness_scale)
    obj = np.minimum(obj, k_cap)
    passive = None
    if passivity is not None:
        passive = passivity.coarse(bgrid)
        obj = np.minimum(obj, passive[0].min(axis=0))
    i = int(np.argmax(obj))
    if not obj[i] > 0:
        what = "is passive and meets the gain margin" if passivity is not None else "meets the gain margin"
        return RobustProfile("infeasible", reason=f"no positive stiffness {what} on every device of the box for any B "
                                                  f"in [0, {upper_b:.6g}] N·s/m")
    if not obj[i] < 1e300:
        return RobustProfile("infeasible", reason="no positive stiffness meets the gain margin: the design is "
                                                  "unbounded (no crossover and no max_stiffness)")
    return RobustProfile("found", damping=float(bgrid[i]), stiffness=float(obj[i]), index=i, passive=passive)
