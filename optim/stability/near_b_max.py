"""K_cr a hair below B_max: the exact rung's honest error there, and the cable's binding crossover in 40 digits.

Near B_max, K_cr → 0 while H = −1/G_n + β(e^{−jθ} − 1) is a difference of two O(β) terms: K = Re H at the
crossover carries the evaluation's rounding times the cancellation ratio ρ = (|1/G_n| + β|e^{−jθ} − 1|)/α.  A
rigid device's closed form is good to a few ulp, so 8·u·ρ bounds that part; a cable's modal evaluation is not
(issue 34: a cable 9.4e-6 below B_max answered 2.875488e-6 N/m where the 40-digit reference says 2.875158e-6, on
the unsafe side, ρ ≈ 1.1e5: its 1/G_n was good to ≈ 1e-9 only).  So a cable with ρ > :data:`RHO_REFINE` gets its
binding crossover re-solved in 40-digit arithmetic on the reference rung's own discretisation
(optim.stability.reference: mpmath's matrix exponential in physical coordinates), by Newton on Im H from the double
answer's θ; K is Re H there.

The inputs themselves are rounded to double (a relative u each): K_cr ∝ (B_max − B) near B_max, so their rounding
moves K_cr by about u·(B + S·B_max)/(B_max − B), S = :data:`B_MAX_SENSITIVITY` bounding Σ|∂ln B_max/∂ln x| over
the device's inputs (mass, damping, sample time, delay, and the cable's).  Both terms enter the estimate.
"""

from __future__ import annotations

import math
from functools import lru_cache

import mpmath as mp
import numpy as np

from models.device import Device
from models.discretize import split_delay

__all__ = ["cancellation_ratio", "input_conditioning", "refine_cable_crossover", "RHO_REFINE", "B_MAX_SENSITIVITY",
           "ROUNDING"]

ROUNDING = 2.220446049250313e-16 / 2
#: cancellation ratio above which a cable's K_cr is re-solved in 40 digits (the double's modal 1/G_n was good to
#: ≈ 2e-12 and once ≈ 1e-9 near B_max in a probe of 12 cables: past 100 the double cannot certify 1e-12 there)
RHO_REFINE = 100.0
#: bound on Σ|∂ln B_max/∂ln x| over the inputs (measured ≤ 3 on rigid and cable devices, docs/properties_analysis.md)
B_MAX_SENSITIVITY = 8.0


def cancellation_ratio(plant, beta: float, theta: float, alpha: float) -> float:
    """ρ = (|1/G_n(θ)| + β|e^{−jθ} − 1|)/α at the crossover (θ, α), dimensionless."""
    inv = abs(complex(plant.inverse_response(np.array([theta]))[0]))
    return (inv + beta * abs(complex(np.expm1(-1j * theta)))) / alpha


def input_conditioning(damping: float, b_max: float | None) -> float:
    """Relative change of K_cr from rounding every input once (module docstring); 0 without a B_max."""
    if not damping > 0.0 or b_max is None or not math.isfinite(b_max) or not b_max > damping:
        return 0.0
    return ROUNDING * (damping + B_MAX_SENSITIVITY * b_max) / (b_max - damping)


@lru_cache(maxsize=64)
def _damperless_h(device: Device, digits: int):
    """−1/G_n(e^{jθ}) of the reference discretisation in digits + 10 digits, kept per device (its matrix exponentials
    are most of a re-solve's cost; a boundary or a design re-solves one device at many B)."""
    from optim.stability.reference import cable_h

    with mp.workdps(digits + 10):
        d, f = split_delay(device.delay_samples)
        return cable_h(device, d, mp.mpf(f), mp.mpf(0))


def refine_cable_crossover(device: Device, damping: float, theta: float, digits: int = 40
                           ) -> tuple[float, float] | None:
    """(θ, α) of the crossover near θ in ``digits`` digits (Newton on Im H of the reference discretisation), or None
    when Newton does not settle within 1e-9 of θ."""
    with mp.workdps(digits + 10):
        beta = mp.mpf(damping) * mp.mpf(device.sample_time) / mp.mpf(device.mass)
        h0 = _damperless_h(device, digits)

        def h(t):
            return h0(t) - beta * (1 - 1 / mp.expj(t))

        th = mp.mpf(theta)
        step = mp.mpf(10) ** (-(digits // 2))
        for _ in range(30):
            v = h(th)
            dv = (h(th * (1 + step)) - v) / (th * step)
            if mp.im(dv) == 0:
                return None
            new = th - mp.im(v) / mp.im(dv)
            done = abs(new - th) <= mp.mpf(10) ** (-digits) * th
            th = new
            if done:
                break
        else:
            return None
        if abs(th / theta - 1) > 1e-9 or th > mp.pi:
            return None
        return float(th), float(mp.re(h(th)))
