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

Along each segment the unstable poles are counted: at a crossing the pole z(g) solves h(z) = g, so it leaves the
circle as the gain g rises when d Im h/dθ > 0 there (a pair at ±θ, or one real pole at θ = π), and enters it when
d Im h/dθ < 0; the sign is that of the refined bracket's ends.  The K = 0⁺ loop is stable when the count ends at 0.
A crossing whose direction is not resolved (a tangency) leaves the path undecided; what neither path decides is
refused (InputError on ``mass``), never guessed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from typing import Literal, NamedTuple

import numpy as np

from models.device import Device
from models.discretize import RigidZOH, StateSpaceZOH
from models.velocity_filter import Rendering, VelocityTransfer, poly_at
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
from optim.stability.margins import NO_DAMPING_REASON, CriticalStiffness, critical_from_crossings, loop_plant
from optim.stability.rendered_rigid import (
    LOOP_B,
    LOOP_K,
    LOOP_M,
    TWO_PI_PIECES,
    cable_real_crossings,
    circle_zero_angles,
    divide_by_one_plus_w,
    equal_form,
    rigid_real_crossings,
    v_zero_at_pi,
)
from optim.stability.undamped_cable import is_undamped_cable

__all__ = ["MassRange", "rendered_critical_stiffness", "rendered_max_stable_damping", "rendered_mass_range",
           "real_crossings", "k_loop", "Decision", "Passage", "clear_caches", "band_crossings", "velocity_response",
           "loop_poles", "POLE_GAP"]

Decision = Literal["stable", "unstable", "undecided"]
#: |V_n| or |A_n| below this counts as a zero of the estimate on the circle (a moving average's 2πk/n)
_TINY = 1e-300
#: π − math.pi (the float π's rounding), as math.pi − θ's correction in the factored V_n
_PI_TAIL = 1.2246467991473532e-16
_TWO_PI_1, _TWO_PI_2, _TWO_PI_3 = TWO_PI_PIECES
#: the samples within this (relative) of a pole of h on the circle are dropped and the pole bracketed by two at
#: θ_p·(1 ∓ POLE_GAP) (real_crossings)
POLE_GAP = 1e-12


@dataclass(frozen=True)
class MassRange:
    """The stable virtual masses at a given (K, B) and filter: the interval of M around the analysed one."""

    min: float
    """M [kg] below which the wall goes unstable (−inf: none)."""
    max: float
    """M [kg] above which the wall goes unstable (inf: none)."""


@lru_cache(maxsize=1024)
def _hints(device: Device, velocity: VelocityTransfer) -> tuple[float, ...]:
    """The scan's cluster angles of a (device, filter): the plant's and the filter's poles and zeros (kept: the
    filter's are np.roots calls, ≈ 0.5 ms of a cable wall's 2 ms scan, the same on every call)."""
    plant = loop_plant(device)
    return (tuple(plant.pole_angles()) + tuple(plant.zero_angles()) + velocity.pole_angles()
            + velocity.zero_angles())


def _grid(device: Device, rendering: Rendering, beta: float) -> np.ndarray:
    hints = _hints(device, rendering.velocity)
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


@lru_cache(maxsize=256)
def _pi_factored(velocity: VelocityTransfer) -> tuple[int, tuple[float, ...]]:
    """(m, R̃) with R = (1 + w)^m·R̃, R̃(−1) ≠ 0: R divided by 1 + w while the remainder is exactly 0 (rational
    arithmetic on the float coefficients), R̃ rounded once (exact for the even average's (1, 0, 1, …, 1)/n and the
    Butterworth's r₀)."""
    m, q = divide_by_one_plus_w([Fraction(c) for c in velocity.r])
    return m, tuple(float(c) for c in q)


def velocity_response(velocity: VelocityTransfer, theta: np.ndarray) -> np.ndarray:
    """T·V(e^{jθ}), as ``VelocityTransfer.response`` (bit for bit) unless V(π) = 0 exactly (``v_zero_at_pi``);
    then in the factored form V_n = (1 − w)(1 + w)^m·R̃(w)/D(w), 1 + w = −expm1(j(π − θ)) with π − θ taken as
    (math.pi − θ) + (π − math.pi) (exact by Sterbenz on [π/2, π], then π's tail): no cancellation near z = −1, where
    Horner's R(w) is rounding (its error ~ε·Σ|r_k| against |R| ~ |π − θ|^m).  At θ = math.pi it is V at that float
    (|1 + w| ≈ 1.2e-16), as e^{−jθ} gives it.

    Where R = c·(1 + w + … + w^{n−1}) (every moving average: ``equal_form``), V_n = c·(1 − wⁿ)/D exactly, with
    1 − wⁿ = −expm1(−j·r), r = nθ − 2πm reduced in extended precision (``_one_minus_w_power``): accurate next to
    each zero 2πk/n (π for even n included), where Horner's R is rounding (≈ 1e-17 against |R| → 0)."""
    n, c = equal_form(velocity)
    if n:
        theta = np.asarray(theta, dtype=float)
        return c * _one_minus_w_power(n, theta) / poly_at(velocity.d, np.exp(-1j * theta))
    if not v_zero_at_pi(velocity):
        return velocity.response(theta)
    m, rt = _pi_factored(velocity)
    theta = np.asarray(theta, dtype=float)
    w = np.exp(-1j * theta)
    out = -np.expm1(-1j * theta) * (-np.expm1(1j * ((math.pi - theta) + _PI_TAIL))) ** m
    return out * poly_at(rt, w) / poly_at(velocity.d, w)


def _one_minus_w_power(n: int, theta: np.ndarray) -> np.ndarray:
    """1 − e^{−jnθ} as −expm1(−j·r), r = nθ − 2πm (m the nearest integer to nθ/2π) computed without cancellation:
    θ = θ₁ + θ₂ split (Veltkamp) so n·θ₁ and n·θ₂ are exact (n < 2²⁶), 2π in three pieces so m·piece is exact, and
    n·θ₁ − m·2π₁ exact by Sterbenz (both within a factor 2 where m ≥ 1): r to a few ulp of itself."""
    split = theta * 134217729.0                    # 2²⁷ + 1
    t1 = split - (split - theta)
    t2 = theta - t1
    m = np.rint(n * theta / (2.0 * math.pi))
    r = (((n * t1 - m * _TWO_PI_1) + n * t2) - m * _TWO_PI_2) - m * _TWO_PI_3
    return -np.expm1(-1j * r)


def loop_poles(velocity: VelocityTransfer) -> tuple[float, ...]:
    """The poles of h_B and h_M on the circle in (0, π) (V's zeros there, ``circle_zero_angles``); InputError on
    ``velocity_filter`` where they are not decided (a transfer function whose R shares a factor with its reversal
    other than (1 + w)^m): never a scan that could list a pole as a crossing."""
    poles = circle_zero_angles(velocity)
    if poles is None:
        raise InputError("velocity_filter", "whether the velocity filter's V(z) has zeros on the unit circle (poles "
                                            "of the damper's and the mass's loops) cannot be decided: its numerator "
                                            "shares a factor with its reversal other than (1 + z⁻¹)^m")
    return poles


def _b_loop(device: Device, rendering: Rendering, mu: float):
    plant = loop_plant(device)
    vel = rendering.velocity

    def h(theta: np.ndarray) -> np.ndarray:
        v = velocity_response(vel, theta)
        with np.errstate(over="ignore", divide="ignore"):
            return (-plant.inverse_response(theta) - mu * v * -np.expm1(-1j * theta)) / _safe(v)
    return h


def _m_loop(device: Device, rendering: Rendering, alpha: float, beta: float):
    plant = loop_plant(device)
    vel = rendering.velocity

    def h(theta: np.ndarray) -> np.ndarray:
        v = velocity_response(vel, theta)
        a = v * -np.expm1(-1j * theta)
        with np.errstate(over="ignore", divide="ignore"):
            return (-plant.inverse_response(theta) - alpha - beta * v) / _safe(a)
    return h


class Passage(NamedTuple):
    """A real value of h on the circle: the gain that puts a closed-loop pole at e^{jθ}, and which way it goes
    (immutable; a named tuple: the certified path builds dozens per K_cr, at a third of a frozen dataclass's cost)."""

    angle: float
    value: float
    outward: int
    """Poles leaving the unit circle as the gain rises through ``value``: +2 / −2 for a pair at ±θ, +1 / −1 for a
    real pole at θ = π, 0 where the direction is not resolved (a tangency).  The pole z(g) solves h(z) = g, so
    dz/dg = 1/h'(z) = jz/(dh/dθ) and its radial part Re(z̄·dz/dg) has the sign of d Im h/dθ."""


def real_crossings(h, grid: np.ndarray, pole_at_pi: bool = False, poles: tuple[float, ...] = ()) -> list[Passage]:
    """Every θ ∈ (0, π] where h is real and non-zero, with its value (both signs) and the poles' direction: the scan
    of optim.stability.crossovers.positive_real_crossings (one refinement of the grid, every sign change of Im h
    refined to 4 ulp, near-tangencies, exact zeros on a sample, the Nyquist point) without its Re h > 0 filter.

    ``pole_at_pi``: θ = π is a pole of h (h_B, h_M where V(π) = 0 exactly, ``v_zero_at_pi``): π is not listed and
    its sample (h's rounding over V's exact 0) joins no bracket.  Near the pole Im h keeps one sign (h ≈ jb/(π − θ)
    for a simple zero of V, a/(π − θ)² + jb/(π − θ) with a, b real for a double one: h(2π − θ) = conj h(θ)).

    ``poles``: θ_p ∈ (0, π) where h has a pole (V's other zeros on the circle, ``loop_poles``: a moving average's
    2πk/n).  The samples within POLE_GAP·θ_p of each are dropped (with V by Horner, h there was V's rounding, of any
    phase: a 25-sample average's scan listed θ = 4π/25 at h ≈ −5e15), two are put at θ_p·(1 ∓ POLE_GAP), and the
    bracket between them, across the pole, is never a crossing; the crossings on either side are bracketed as
    anywhere else.  (Next to a simple pole h ≈ c/(θ − θ_p): within POLE_GAP of it |h| is ≳ 1e12 times its size a
    radian away, and Im h keeps the sign of Im c on each side unless c is real.)"""
    if poles:
        sides = np.array([p * (1.0 + s * POLE_GAP) for p in poles for s in (-1.0, 1.0)])
        near = np.zeros(grid.shape, dtype=bool)
        for p in poles:
            near |= np.abs(grid - p) <= POLE_GAP * p
        grid = np.union1d(grid[~near], sides)
    grid, values = refine_grid(h, grid)
    if pole_at_pi and grid[-1] == math.pi:
        grid, values = grid[:-1], values[:-1]
    across = np.zeros(grid.size - 1, dtype=bool)      # brackets across a pole of h: no crossing
    if poles:
        keep = np.ones(grid.shape, dtype=bool)
        for p in poles:
            keep &= ~(np.abs(grid - p) < POLE_GAP * p * (1.0 - 1e-3))    # refine_grid's bisections toward the pole
        grid, values = grid[keep], values[keep]
        across = np.zeros(grid.size - 1, dtype=bool)
        for p in poles:
            across |= (grid[:-1] < p) & (grid[1:] > p)
    im, re = values.imag, values.real
    found: list[Passage] = []
    with np.errstate(divide="ignore", invalid="ignore"):
        turn = np.abs(np.angle(values[1:] / values[:-1]))
    # a sign change of Im h across which arg h jumps by ≈ π is a pole of h on the circle (a zero of V or A there:
    # a moving average's 2πk/n, the Butterworth's z = −1), where the moving gain → ±∞: not a crossing
    idx = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0) & (turn < 0.5 * math.pi) & ~across)[0]
    if idx.size:
        roots = solve_brackets(lambda t: h(t).imag, grid[idx], grid[idx + 1], im[idx], im[idx + 1])
        found += [Passage(float(t), float(v), 2 if im[i + 1] > 0 else -2)
                  for t, v, i in zip(roots, h(roots).real, idx) if v != 0.0]
    # a near-tangency's two crossings (optim.stability.crossovers.tangential_pairs) move their poles opposite ways;
    # their order along θ tells which: Im h rises through the first one when it was negative between samples
    for sign in (1.0, -1.0):
        pair = tangential_pairs(lambda t: sign * h(t), grid, sign * values)    # called here, not kept
        for j in range(0, len(pair) - 1, 2):
            first, second = pair[j], pair[j + 1]
            if any(first.angle < p < second.angle for p in poles):
                continue                       # a pole between them, not a tangency
            mid = complex(h(np.array([0.5 * (first.angle + second.angle)]))[0]).imag
            out = 2 if mid < 0 else -2
            found += [Passage(first.angle, sign * first.value, out), Passage(second.angle, sign * second.value, -out)]
    for i in np.nonzero(im[1:-1] == 0.0)[0] + 1:
        if re[i] != 0.0:
            out = 2 if (im[i - 1] < 0 < im[i + 1]) else -2 if (im[i - 1] > 0 > im[i + 1]) else 0
            found.append(Passage(float(grid[i]), float(re[i]), out))
    v_pi = 0.0 if pole_at_pi else complex(h(np.array([math.pi]))[0]).real
    if v_pi != 0.0:
        found = [c for c in found if math.pi - c.angle > 1e-9]
        below = im[-2] if grid[-1] == math.pi else im[-1]
        found.append(Passage(math.pi, v_pi, 1 if below < 0 else -1 if below > 0 else 0))
    return sorted((c for c in found if math.isfinite(c.value) and abs(c.value) < 1e250), key=lambda c: c.angle)


def _walk(passages, start: float, end: float, unstable: int | None) -> int | None:
    """Unstable poles after moving a gain from ``start`` to ``end`` across ``passages`` (None: not resolved)."""
    if unstable is None or end == start:
        return unstable
    up = end > start
    for c in sorted(passages, key=lambda c: c.value, reverse=not up):
        if (start < c.value <= end) if up else (end <= c.value < start):
            if c.outward == 0:
                return None
            unstable += c.outward if up else -c.outward
    return unstable if unstable >= 0 else None


def _certified(device: Device, rendering: Rendering, loop: int, alpha: float, beta: float,
               mu: float) -> list[Passage] | None:
    """The real values of the loop's h by optim.stability.rendered_rigid's certified isolation (no scan; a rigid
    plant, or a damped cable's factored loop), or None where its certificate does not close (a tangency, a zero of
    the estimate on the circle, a cable not factored or whose h is a difference of far larger terms)."""
    plant = loop_plant(device)
    try:
        if isinstance(plant, RigidZOH):
            found = rigid_real_crossings(plant, rendering, loop, alpha, beta, mu)
        elif isinstance(plant, StateSpaceZOH) and not is_undamped_cable(device):
            found = cable_real_crossings(plant, rendering, loop, alpha, beta, mu)
        else:
            return None
    except (ZeroDivisionError, FloatingPointError, ValueError, np.linalg.LinAlgError):
        return None
    return None if found is None else list(map(Passage._make, found))


@lru_cache(maxsize=1024)
def _mass_crossings(device: Device, rendering: Rendering, beta: float) -> tuple[Passage, ...]:
    """μ values (dimensionless) where the K = 0⁺ loop at β gets a pole on the circle."""
    fast = _certified(device, rendering, LOOP_M, 0.0, beta, 0.0)
    if fast is not None:
        return tuple(fast)
    return tuple(real_crossings(_m_loop(device, rendering, 0.0, beta), _grid(device, rendering, beta),
                                v_zero_at_pi(rendering.velocity), loop_poles(rendering.velocity)))


@lru_cache(maxsize=1024)
def _damper_crossings(device: Device, rendering: Rendering, mu: float) -> tuple[Passage, ...]:
    """β values (dimensionless) where the K = 0⁺ loop at μ gets a pole on the circle."""
    fast = _certified(device, rendering, LOOP_B, 0.0, 0.0, mu)
    if fast is not None:
        return tuple(fast)
    return tuple(real_crossings(_b_loop(device, rendering, mu), _grid(device, rendering, 0.0),
                                v_zero_at_pi(rendering.velocity), loop_poles(rendering.velocity)))


def clear_caches() -> None:
    """Forget the K = 0⁺ loop's crossings kept per (device, filter, gain) (benchmarks time a wall not seen before)."""
    _mass_crossings.cache_clear()
    _damper_crossings.cache_clear()


def _reduced_loop(device: Device, rendering: Rendering, beta: float, mu: float) -> Decision:
    """Whether the K = 0⁺ loop (every pole but z = 1) is stable at (β, μ): the unstable poles counted along the
    two paths of the module docstring (the first that resolves its count answers)."""
    # without physical damping the loop at B = 0 keeps a pole at z = 1 for every M (G's double pole meets A's double
    # zero): a walk of M at B = 0 starts on the circle, so B goes first there
    order = (("damper", "mass"),) if device.damping == 0.0 else (("mass", "damper"), ("damper", "mass"))
    for first, _ in order:
        if first == "mass":
            n = _walk(_mass_crossings(device, rendering, 0.0) if mu else (), 0.0, mu, 0)
            n = _walk(_damper_crossings(device, rendering, mu) if beta else (), 0.0, beta, n)
        else:
            n = _walk(_damper_crossings(device, rendering, 0.0) if beta else (), 0.0, beta, 0)
            n = _walk(_mass_crossings(device, rendering, beta) if mu else (), 0.0, mu, n)
        if n is not None:
            return "stable" if n == 0 else "unstable"
    return "undecided"


def _check(device: Device, rendering: Rendering, damping: float) -> None:
    if not (math.isfinite(damping) and damping >= 0.0):
        raise InputError("damping", "virtual damping B must be finite and ≥ 0")
    if is_undamped_cable(device):
        raise InputError("velocity_filter", "a velocity filter or a virtual mass on a cable with every damping 0 is "
                                            "not analysed (its mode sits on the unit circle)")


def rendered_max_stable_damping(device: Device, rendering: Rendering) -> float:
    """B_max [N·s/m] at this M and filter: the largest B with a stable K = 0⁺ loop (B from 0 at this M, the poles
    counted across each crossing); inf when no B destabilises it, 0 when no B > 0 is stable, nan when the count is
    not resolved."""
    _check(device, rendering, 0.0)
    mu = rendering.mass / device.mass
    if device.damping == 0.0 and mu != 0.0:
        # the walk of M at B = 0 starts on the circle (see _reduced_loop): B_max at this M is not resolved
        return math.nan
    n = _walk(_mass_crossings(device, rendering, 0.0) if mu else (), 0.0, mu, 0)
    passages = sorted((c for c in _damper_crossings(device, rendering, mu) if c.value > 0.0), key=lambda c: c.value)
    last_stable_end = 0.0
    for c in passages:
        if n is None or c.outward == 0:
            return math.nan
        before = n
        n += c.outward
        if before == 0 and n > 0:
            last_stable_end = c.value
        elif n < 0:
            return math.nan
    if n is None:
        return math.nan
    return math.inf if n == 0 else last_stable_end * device.damping_scale


def rendered_critical_stiffness(device: Device, damping: float, rendering: Rendering) -> CriticalStiffness:
    """K_cr(B) of the wall C(z) = K + B·V(z) + M·A(z): every crossover of h_K (module docstring)."""
    _check(device, rendering, damping)
    beta, mu = damping / device.damping_scale, rendering.mass / device.mass
    if device.damping + damping <= 0.0:
        if mu != 0.0 and not rendering.velocity.is_backward_difference:
            # C = K + M·A with a filtered A: its lag acts like damping (M·s²/(τs + 1) ≈ Ms² + jMτω³), so the double
            # pole at z = 1 may split inwards; the z → 1 argument above needs b + B > 0 (the property run found
            # such walls stable at small K)
            raise InputError("damping", "with no physical or virtual damping (b = B = 0) a filtered virtual mass "
                                        "decides the poles at z = 1, which this analysis does not resolve: give B > 0")
        return CriticalStiffness(0.0, None, (), damping, 0.0, reason=NO_DAMPING_REASON)
    b_max = rendered_max_stable_damping(device, rendering) if damping > 0.0 else None
    if b_max is not None and math.isnan(b_max):
        b_max = None
    state = _reduced_loop(device, rendering, beta, mu)
    if state == "undecided":
        raise InputError("mass", "whether the loop with K → 0⁺ is stable at this virtual mass, damping and filter "
                                 "cannot be decided: a crossing on every path whose direction is not resolved")
    if state == "unstable":
        return CriticalStiffness(0.0, None, (), damping, b_max, reason=(
            f"with B = {damping:.6g} N·s/m, M = {rendering.mass:.6g} kg and this velocity filter the loop is "
            "unstable already as K → 0⁺: no positive stiffness is stable"))
    fast = _certified(device, rendering, LOOP_K, 0.0, beta, mu)
    if fast is not None:
        found = [Crossing(c.angle, c.value) for c in fast if c.value > 0.0]
    else:
        found = positive_real_crossings(k_loop(device, rendering, beta, mu), _grid(device, rendering, beta))
    return critical_from_crossings(device, found, damping, b_max)


def band_crossings(device: Device, rendering: Rendering, beta: float) -> list[tuple[float, float, int]]:
    """(α, θ, change of the unstable count) of every K > 0 crossover of h_K at β and this filter and M, sorted by α
    (optim.stability.stable_band's input past B_max): the real crossings of h_K with their poles' direction (0: a
    crossing whose direction is not resolved)."""
    h = k_loop(device, rendering, beta, rendering.mass / device.mass)
    found = real_crossings(h, _grid(device, rendering, beta))
    return sorted((c.value, c.angle, c.outward) for c in found if c.value > 0.0)


def rendered_mass_range(device: Device, stiffness: float, damping: float, rendering: Rendering) -> MassRange | None:
    """The interval of virtual mass M [kg] around ``rendering.mass`` on which the wall (K, B) and filter stay
    stable: the nearest real values of h_M below and above it (None when the wall is unstable at this M)."""
    kcr = rendered_critical_stiffness(device, damping, rendering)
    if not stiffness < kcr.critical_stiffness:
        return None
    alpha, beta = stiffness / device.stiffness_scale, damping / device.damping_scale
    mu = rendering.mass / device.mass
    passages = _certified(device, rendering, LOOP_M, alpha, beta, mu)
    if passages is None:
        passages = real_crossings(_m_loop(device, rendering, alpha, beta), _grid(device, rendering, beta),
                                  v_zero_at_pi(rendering.velocity), loop_poles(rendering.velocity))
    values = [c.value for c in passages if c.outward != 0]
    lo = max((v for v in values if v < mu), default=-math.inf)
    hi = min((v for v in values if v > mu), default=math.inf)
    return MassRange(lo * device.mass, hi * device.mass)
