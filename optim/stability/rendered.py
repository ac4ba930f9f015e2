"""K_cr, B_max and the stable range of the virtual mass for any rendered wall C(z) = K + B·V(z) + M·A(z), exactly.

The closed loop 1 + C(z)·G(z) = 0 has a pole at z = e^{jθ} exactly when (dimensionless: α = KT²/m, β = BT/m,
μ = M/m, V_n = T·V, A_n = T²·A, G_n = G·m/T²)

    α + β·V_n(θ) + μ·A_n(θ) = −1/G_n(e^{jθ}).

Each gain enters affinely, so the one that moves is solved for and the others are held fixed:

    K:  h_K(θ) = −1/G_n − β V_n − μ A_n          (K_cr: the smallest positive real value of h_K)
    B:  h_B(θ) = (−1/G_n − μ A_n)/V_n            (B_max at this M: the smallest positive real value at α = 0⁺)
    M:  h_M(θ) = (−1/G_n − α − β V_n)/A_n        (the stable range of M: the real values nearest the given M)

A closed-loop pole crosses the unit circle only where the moving gain equals a real value of its h, so each
answer is the scan of optim.stability.crossovers (the adaptive grid, every bracket refined to 4 ulp in θ) of the
right h; no Padé, no fixed grid.

Why the smallest positive crossover of h_K is K_cr (as optim.stability.margins argues for today's wall): at K = 0
every velocity estimate has V(1) = 0, so z = 1 is a closed-loop pole for every B and M, and with K = 0⁺ it moves
inwards, z − 1 ≈ −K·T/(b + B) (V'(1)·T = 1; the mass term is O((z − 1)²)).  The other poles are those of the loop
1 + (B·V + M·A)·G with z = 1 removed (the "K = 0⁺ loop").  It is stable when a path of (B, M) from (0, 0), where
every pole but z = 1 lies inside (a damped device, a stable filter), crosses no real value of its h:

* path 1: M from 0 at B = 0 (h_M with α = β = 0), then B from 0 at M (h_B);
* path 2: B from 0 at M = 0 (h_B with μ = 0), then M from 0 at B (h_M with α = 0).

A segment with no crossing keeps the state of its start; from a stable start, one crossing (a transversal pair of
poles, or a real one) leaves it unstable.  Whatever neither path decides is refused, never guessed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np

from models.device import Device
from models.velocity_filter import Rendering
from optim.errors import InputError
from optim.stability.crossovers import (
    Crossing,
    positive_real_crossings,
    refine_grid,
    scan_grid,
    solve_brackets,
    tangential_pairs,
    theta_min,
)
from optim.stability.margins import NO_DAMPING_REASON, CriticalStiffness, Crossover, loop_plant
from optim.stability.undamped_cable import is_undamped_cable

__all__ = ["MassRange", "rendered_critical_stiffness", "rendered_max_stable_damping", "rendered_mass_range",
           "real_crossings", "k_loop", "Decision"]

Decision = Literal["stable", "unstable", "undecided"]
#: |V_n| or |A_n| below this counts as a zero of the estimate on the circle (a moving average's 2πk/n)
_TINY = 1e-300


@dataclass(frozen=True)
class MassRange:
    """The stable virtual masses at a given (K, B) and filter: the interval of M around the analysed one."""

    min: float
    """M [kg] below which the wall goes unstable (−inf: none)."""
    max: float
    """M [kg] above which the wall goes unstable (inf: none)."""


def _grid(device: Device, rendering: Rendering, beta: float) -> np.ndarray:
    plant = loop_plant(device)
    hints = (tuple(plant.pole_angles()) + tuple(plant.zero_angles()) + rendering.velocity.pole_angles()
             + rendering.velocity.zero_angles())
    return scan_grid(theta_min(device.delta + beta, device.delay_samples), device.delay_samples, hints,
                     width_hint=max(device.delta, 1e-6))


def _safe(x: np.ndarray) -> np.ndarray:
    return np.where(np.abs(x) < _TINY, _TINY, x)


def k_loop(device: Device, rendering: Rendering, beta: float, mu: float):
    """h_K(θ) = −1/G_n − β V_n − μ A_n (dimensionless)."""
    plant = loop_plant(device)

    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) - rendering.controller_response(theta, beta, mu)
    return h


def _b_loop(device: Device, rendering: Rendering, mu: float):
    plant = loop_plant(device)
    vel = rendering.velocity

    def h(theta: np.ndarray) -> np.ndarray:
        v = vel.response(theta)
        with np.errstate(over="ignore", divide="ignore"):
            return (-plant.inverse_response(theta) - mu * v * -np.expm1(-1j * theta)) / _safe(v)
    return h


def _m_loop(device: Device, rendering: Rendering, alpha: float, beta: float):
    plant = loop_plant(device)
    vel = rendering.velocity

    def h(theta: np.ndarray) -> np.ndarray:
        v = vel.response(theta)
        a = v * -np.expm1(-1j * theta)
        with np.errstate(over="ignore", divide="ignore"):
            return (-plant.inverse_response(theta) - alpha - beta * v) / _safe(a)
    return h


def real_crossings(h, grid: np.ndarray) -> list[Crossing]:
    """Every θ ∈ (0, π] where h is real and non-zero, with its value (both signs): the scan of
    optim.stability.crossovers.positive_real_crossings (one refinement of the grid, every sign change of Im h
    refined to 4 ulp, near-tangencies, exact zeros on a sample, the Nyquist point) without its Re h > 0 filter."""
    grid, values = refine_grid(h, grid)
    im, re = values.imag, values.real
    found: list[Crossing] = []
    with np.errstate(divide="ignore", invalid="ignore"):
        turn = np.abs(np.angle(values[1:] / values[:-1]))
    # a sign change of Im h across which arg h jumps by ≈ π is a pole of h on the circle (a zero of V or A there:
    # a moving average's 2πk/n, the Butterworth's z = −1), where the moving gain → ±∞: not a crossing
    idx = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0) & (turn < 0.5 * math.pi))[0]
    if idx.size:
        roots = solve_brackets(lambda t: h(t).imag, grid[idx], grid[idx + 1], im[idx], im[idx + 1])
        found += [Crossing(float(t), float(v)) for t, v in zip(roots, h(roots).real) if v != 0.0]
    found += tangential_pairs(h, grid, values)
    found += [Crossing(c.angle, -c.value) for c in tangential_pairs(lambda t: -h(t), grid, -values)]
    for i in np.nonzero(im[1:-1] == 0.0)[0] + 1:
        if re[i] != 0.0:
            found.append(Crossing(float(grid[i]), float(re[i])))
    v_pi = complex(h(np.array([math.pi]))[0]).real
    if v_pi != 0.0:
        found = [c for c in found if math.pi - c.angle > 1e-9]
        found.append(Crossing(math.pi, v_pi))
    return sorted((c for c in found if math.isfinite(c.value) and abs(c.value) < 1e250), key=lambda c: c.angle)


def _segment(values: list[float], start: float, end: float) -> int:
    """Crossings strictly between ``start`` and ``end`` (or at ``end``)."""
    lo, hi = min(start, end), max(start, end)
    return sum(1 for v in values if lo < v <= hi) if end >= start else sum(1 for v in values if lo <= v < hi)


def _after(state: Decision, crossings: int) -> Decision:
    if crossings == 0:
        return state
    if state == "stable" and crossings == 1:
        return "unstable"
    return "undecided"


@lru_cache(maxsize=1024)
def _mass_crossings(device: Device, rendering: Rendering, beta: float) -> tuple[float, ...]:
    """μ values (dimensionless) where the K = 0⁺ loop at β gets a pole on the circle."""
    h = _m_loop(device, rendering, 0.0, beta)
    return tuple(c.value for c in real_crossings(h, _grid(device, rendering, beta)))


@lru_cache(maxsize=1024)
def _damper_crossings(device: Device, rendering: Rendering, mu: float) -> tuple[float, ...]:
    """β values (dimensionless) where the K = 0⁺ loop at μ gets a pole on the circle."""
    h = _b_loop(device, rendering, mu)
    return tuple(c.value for c in real_crossings(h, _grid(device, rendering, 0.0)))


def _on_path(crossings, start: float, end: float) -> int:
    """Crossings on the segment of a gain from ``start`` to ``end`` (none to scan for when it does not move)."""
    return 0 if end == start else _segment(list(crossings()), start, end)


def _reduced_loop(device: Device, rendering: Rendering, beta: float, mu: float) -> Decision:
    """Whether the K = 0⁺ loop (every pole but z = 1) is stable at (β, μ), by the two paths of the docstring."""
    p1 = _after(_after("stable", _on_path(lambda: _mass_crossings(device, rendering, 0.0), 0.0, mu)),
                _on_path(lambda: _damper_crossings(device, rendering, mu), 0.0, beta))
    if p1 != "undecided":
        return p1
    return _after(_after("stable", _on_path(lambda: _damper_crossings(device, rendering, 0.0), 0.0, beta)),
                  _on_path(lambda: _mass_crossings(device, rendering, beta), 0.0, mu))


def _check(device: Device, rendering: Rendering, damping: float) -> None:
    if not (math.isfinite(damping) and damping >= 0.0):
        raise InputError("damping", "virtual damping B must be finite and ≥ 0")
    if is_undamped_cable(device):
        raise InputError("velocity_filter", "a velocity filter or a virtual mass on a cable with every damping 0 is "
                                            "not analysed (its mode sits on the unit circle)")


def rendered_max_stable_damping(device: Device, rendering: Rendering) -> float:
    """B_max [N·s/m] at this M and filter: the largest B with a stable K = 0⁺ loop, reached from B = 0 at this M
    (inf when no B destabilises it; 0 when B = 0⁺ is already unstable)."""
    _check(device, rendering, 0.0)
    mu = rendering.mass / device.mass
    start = _after("stable", _on_path(lambda: _mass_crossings(device, rendering, 0.0), 0.0, mu))
    if start != "stable":
        return 0.0
    up = [v for v in _damper_crossings(device, rendering, mu) if v > 0.0]
    return min(up, default=math.inf) * device.damping_scale


def rendered_critical_stiffness(device: Device, damping: float, rendering: Rendering) -> CriticalStiffness:
    """K_cr(B) of the wall C(z) = K + B·V(z) + M·A(z): every crossover of h_K (module docstring)."""
    _check(device, rendering, damping)
    beta, mu = damping / device.damping_scale, rendering.mass / device.mass
    if device.damping + damping <= 0.0:
        return CriticalStiffness(0.0, None, (), damping, 0.0, reason=NO_DAMPING_REASON)
    b_max = rendered_max_stable_damping(device, rendering) if damping > 0.0 else None
    state = _reduced_loop(device, rendering, beta, mu)
    if state == "undecided":
        raise InputError("mass", "whether the loop with K → 0⁺ is stable at this virtual mass, damping and filter "
                                 "cannot be decided from the crossings (several crossings on every path)")
    if state == "unstable":
        return CriticalStiffness(0.0, None, (), damping, b_max, reason=(
            f"with B = {damping:.6g} N·s/m, M = {rendering.mass:.6g} kg and this velocity filter the loop is "
            "unstable already as K → 0⁺: no positive stiffness is stable"))
    h = k_loop(device, rendering, beta, mu)
    found = positive_real_crossings(h, _grid(device, rendering, beta))
    scale, t = device.stiffness_scale, device.sample_time
    crossovers = tuple(Crossover(frequency=c.angle / t, stiffness=c.value * scale) for c in found)
    if not crossovers:
        return CriticalStiffness(math.inf, None, (), damping, b_max,
                                 reason="no phase crossover: every positive stiffness is stable")
    best = min(crossovers, key=lambda c: c.stiffness)
    return CriticalStiffness(best.stiffness, best.frequency, crossovers, damping, b_max)


def rendered_mass_range(device: Device, stiffness: float, damping: float, rendering: Rendering) -> MassRange | None:
    """The interval of virtual mass M [kg] around ``rendering.mass`` on which the wall (K, B) and filter stay
    stable: the nearest real values of h_M below and above it (None when the wall is unstable at this M)."""
    kcr = rendered_critical_stiffness(device, damping, rendering)
    if not stiffness < kcr.critical_stiffness:
        return None
    alpha, beta = stiffness / device.stiffness_scale, damping / device.damping_scale
    mu = rendering.mass / device.mass
    h = _m_loop(device, rendering, alpha, beta)
    values = [c.value for c in real_crossings(h, _grid(device, rendering, beta))]
    lo = max((v for v in values if v < mu), default=-math.inf)
    hi = min((v for v in values if v > mu), default=math.inf)
    return MassRange(lo * device.mass, hi * device.mass)
