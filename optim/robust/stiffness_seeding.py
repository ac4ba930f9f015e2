"""Seeding the robust stiffness NLP from the coarse profile's best point (B₀, K₀).

With passivity, the cuts start at the binding angles of the corners near the smallest passive K at B₀, at π
and at the kernel's zeros (as optim.stiffness.design); every scenario tracks the crossovers of its boundary
curve at B₀ (those within 50× of K₀), on the B interval where no scenario's crossovers are born or die.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optim.robust.passivity_cuts import PassivityCuts
from optim.robust.stiffness_profile import RobustProfile, Scenario
from optim.stiffness.loop import loop_matrices
from optim.stiffness.profile import BoundaryCurve, crossings_at

__all__ = ["Seed", "seed", "piece_bounds"]


@dataclass(frozen=True)
class Seed:
    """Where the NLP starts and what it is scaled by."""

    b_bounds: tuple[float, float]
    """the fold-free B interval [N·s/m] common to every scenario."""
    k_ref: float
    """K scale [N/m] (K₀)."""
    b_ref: float
    """B scale [N·s/m]."""
    x_kb: tuple[float, float]
    """(K/K_ref, B/B_ref) to start from."""
    global_params: np.ndarray
    """(g, K_ref, B_ref, K cap, B cap) as problem.py wants them."""
    scenario_params: tuple[np.ndarray, ...]
    """each scenario's loop matrices and scales."""
    n_states: int


def piece_bounds(curve: BoundaryCurve, theta: float) -> tuple[float, float]:
    """The θ range of the boundary piece that holds θ (a crossover's bounds in the NLP)."""
    for p in curve.pieces:
        lo, hi = min(p.theta_lo, p.theta_hi), max(p.theta_lo, p.theta_hi)
        if lo <= theta <= hi:
            return lo, hi
    return max(theta * 0.5, 1e-9), min(math.pi, theta * 1.5)


def _interval(sc: Scenario, beta: float, beta_hi: float) -> tuple[float, float]:
    """The scenario's fold-free β interval around β (as optim.stiffness.design._interval)."""
    pts = [0.0, *sc.curve.breakpoints, beta_hi]
    lo = max(p for p in pts if p <= beta)
    hi = min((p for p in pts if p > beta), default=beta_hi)
    w = hi - lo
    return (lo + 1e-9 * w if lo > 0 else 0.0), hi - 1e-9 * w


def _seed_cuts(passivity: PassivityCuts, profile: RobustProfile) -> None:
    """For every corner whose passive K at B₀ is within 20 % of the smallest: its binding angle there, π and
    the kernel's zeros (where P = −B·cos((n+1)θ) bounds B alone)."""
    pk, pth, who = profile.passive
    i = profile.index
    for j in np.nonzero(pk[:, i] <= 1.2 * pk[who[i], i])[0]:
        n = passivity.corners[j].delay_samples
        for theta in (float(pth[j, i]), math.pi, *(2 * math.pi * q / (2 * n + 1) for q in range(1, min(n, 4) + 1))):
            passivity.add(int(j), theta)


def seed(scenarios: list[Scenario], profile: RobustProfile, g: float, upper_b: float, k_cap: float, b_cap: float,
         passivity: PassivityCuts | None) -> Seed:
    """The NLP's start at the profile's best point; sets each scenario's tracked crossovers and Nyquist flag."""
    b0, k0 = profile.damping, profile.stiffness
    if passivity is not None:
        _seed_cuts(passivity, profile)
    lo, hi = 0.0, upper_b
    for sc in scenarios:
        bs = sc.device.damping_scale
        a, c = _interval(sc, b0 / bs, upper_b / bs)
        lo, hi = max(lo, a * bs), min(hi, c * bs)
        far = 50.0 * k0 / g / sc.device.stiffness_scale
        sc.crossings = [(t, piece_bounds(sc.curve, t)) for t, al in crossings_at(sc.curve, b0 / bs, with_alpha=True)
                        if al <= far]
        sc.nyquist = bool(sc.curve.nyquist_alpha(np.array([b0 / bs]))[0] > 0)
    k_ref, b_ref = k0, max(b0, 1e-2 * upper_b)
    gparams = np.array([g, k_ref, b_ref, k_cap if math.isfinite(k_cap) else 1e300,
                        b_cap if math.isfinite(b_cap) else 1e300])
    flats = tuple(np.concatenate([loop_matrices(sc.device).flat(), [sc.device.stiffness_scale,
                                                                    sc.device.damping_scale]])
                  for sc in scenarios)
    return Seed((lo, hi), k_ref, b_ref, (1.0, b0 / b_ref), gparams, flats, loop_matrices(scenarios[0].device).n)
