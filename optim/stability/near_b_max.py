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
moves K_cr by about u·(B + S·B_max)/(B_max − B), S = Σ|∂ln B_max/∂ln x| over the device's inputs (mass, damping,
sample time, delay, and the cable's), measured by differences where the term can matter (B within 1 % of B_max:
rigid devices gave ≈ 2, a cable 266), else :data:`B_MAX_SENSITIVITY`.  Both terms enter the estimate.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import mpmath as mp
import numpy as np

from models.device import Device
from models.discretize import split_delay

__all__ = ["cancellation_ratio", "input_conditioning", "b_max_sensitivity", "MEASURE_WITHIN", "refine_cable_crossover", "RHO_REFINE", "B_MAX_SENSITIVITY",
           "ROUNDING"]

ROUNDING = 2.220446049250313e-16 / 2
#: cancellation ratio above which a cable's K_cr is re-solved in 40 digits (the double's modal 1/G_n was good to
#: ≈ 2e-12 and once ≈ 1e-9 near B_max in a probe of 12 cables: past 100 the double cannot certify 1e-12 there)
RHO_REFINE = 100.0
#: Σ|∂ln B_max/∂ln x| assumed where it is not measured (B more than 1 % below B_max, where the term stays < 1e-13),
#: and the least used where it is
B_MAX_SENSITIVITY = 8.0
#: B within this relative distance of B_max: the sensitivity is measured
MEASURE_WITHIN = 1e-2


def cancellation_ratio(plant, beta: float, theta: float, alpha: float) -> float:
    """ρ = (|1/G_n(θ)| + β|e^{−jθ} − 1|)/α at the crossover (θ, α), dimensionless."""
    inv = abs(complex(plant.inverse_response(np.array([theta]))[0]))
    return (inv + beta * abs(complex(np.expm1(-1j * theta)))) / alpha


def b_max_sensitivity(device: Device, b_max: float) -> float:
    """Σ|∂ln B_max/∂ln x| over the device's nonzero inputs x (mass, damping, sample time, delay; a cable's masses,
    dampings and stiffness instead of mass and damping), by forward differences of relative step 1e-6, doubled;
    never below B_MAX_SENSITIVITY.  A cable measured 266 where rigid devices give ≈ 2."""
    from optim.stability.margins import max_stable_damping

    base: dict[str, Any] = device.model_dump(exclude_none=True)
    keys: list[tuple[str, ...]] = [("sample_time",), ("delay",)]
    keys += [("cable", k) for k in base["cable"]] if "cable" in base else [("mass",), ("damping",)]
    total = 0.0
    for key in keys:
        fields = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
        where = fields if len(key) == 1 else fields["cable"]
        if not where.get(key[-1]):
            continue
        where[key[-1]] *= 1.0 + 1e-6
        if len(key) == 2:
            fields.pop("mass", None)
            fields.pop("damping", None)
        try:
            moved = max_stable_damping(Device(**fields))
        except ValueError:
            return math.inf
        if not math.isfinite(moved):
            return math.inf
        total += abs(moved / b_max - 1.0) / 1e-6
    return max(2.0 * total, B_MAX_SENSITIVITY)


def input_conditioning(damping: float, b_max: float | None, sensitivity: float = B_MAX_SENSITIVITY) -> float:
    """Relative change of K_cr from rounding every input once (module docstring); 0 without a B_max."""
    if not damping > 0.0 or b_max is None or not math.isfinite(b_max) or not b_max > damping:
        return 0.0
    return ROUNDING * (damping + sensitivity * b_max) / (b_max - damping)


@lru_cache(maxsize=64)
def _damperless_h(device: Device, digits: int):
    """−1/G_n(e^{jθ}) of the reference discretisation in digits + 10 digits, kept per device (its matrix exponentials
    are most of a re-solve's cost; a boundary or a design re-solves one device at many B)."""
    from optim.stability.reference import cable_h

    with mp.workdps(digits + 10):
        d, f = split_delay(device.delay_samples)
        return cable_h(device, d, mp.mpf(f), mp.mpf(0))


def refine_cable_crossover(device: Device, damping: float, theta: float, digits: int = 40,
                           velocity: tuple[tuple[float, ...], tuple[float, ...]] | None = None, mu: float = 0.0
                           ) -> tuple[float, float] | None:
    """(θ, α) of the crossover near θ in ``digits`` digits (Newton on Im H of the reference discretisation), or None
    when Newton does not settle within 1e-9 of θ.  ``velocity`` = (R, D) and ``mu`` = M/m: a rendered wall's filter
    (models.velocity_filter.VelocityTransfer's coefficients, taken as exact) and virtual mass: H = −1/G_n − β·V_n −
    μ·V_n·(1 − w), V_n = (1 − w)·R(w)/D(w), w = e^{−jθ}, all in ``digits`` digits."""
    with mp.workdps(digits + 10):
        beta = mp.mpf(damping) * mp.mpf(device.sample_time) / mp.mpf(device.mass)
        h0 = _damperless_h(device, digits)
        r_c, d_c = ([mp.mpf(c) for c in velocity[0]], [mp.mpf(c) for c in velocity[1]]) if velocity else ([1], [1])
        mu_mp = mp.mpf(mu)

        def poly(coeffs, w):                 # Σ c_k w^k by Horner, ascending coefficients
            out = mp.mpf(0)
            for c in reversed(coeffs):
                out = out * w + c
            return out

        def h(t):
            w = 1 / mp.expj(t)
            if velocity is None and mu == 0.0:
                return h0(t) - beta * (1 - w)
            v = (1 - w) * poly(r_c, w) / poly(d_c, w)
            return h0(t) - beta * v - mu_mp * v * (1 - w)

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
