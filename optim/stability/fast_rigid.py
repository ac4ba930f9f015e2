"""Exact K_cr(B) of a rigid device without a frequency scan (issue 20): one or two bracketed Newton solves.

Notation of optim.stability.margins (dimensionless: θ = ωT, α = K T²/m, β = B T/m).  The rigid loop is
1/G_n(z) = (z − 1)(z − p) z^{d+m} / (A·Π(z + q_i)), p = e^{−δ}, with the numerator's zeros −q_i on the
negative real axis (checked here; anything else falls back to the scan): for a whole-sample delay
N(z) = φ₂(δ)(z + 1) + c(δ) (one zero, m = 0); a fractional delay f adds the 1/z term of the modified
z-transform, so z·N(z) = A z² + B z + C (two zeros, m = 1).  With z − 1 = 2j·sin(θ/2)·e^{jθ/2}:

    H(θ) = −1/G_n − β(1 − e^{−jθ}) = −2j·sin(θ/2)·(R e^{jφ} + β e^{−jθ/2}),
    φ(θ) = (d + m + ½)θ + arg(z − p) − Σ arg(z + q_i),      R(θ) = |z − p| / (A Π|z + q_i|).

Why no scan is needed (each step is a line of algebra on these two forms):

* R rises with θ (|z − p| rises, every |z + q| falls), so g = β cos(θ/2)/R falls.
* A K > 0 crossover (H real and positive) is exactly R cos φ = −β cos(θ/2) with R sin φ > β sin(θ/2),
  i.e. F(θ) = φ − asin g = π/2 (mod 2π) where R > β, and there
  K = k(θ) = 2s·u / (√(u + β²s²) + βs),  s = sin(θ/2), u = R² − β².  k rises with θ (it rises in s²
  and in u, and both rise), so the K > 0 crossover of lowest frequency is the binding one, every later
  one (the Nyquist point included: H(π) = 2(R − β) when φ(π) ≡ π/2) has a larger K.
* φ' = d + m + ½ + Re z/(z − p) − Σ Re z/(z + q_i).  Re z/(z − p) ≥ 1/(1 + p); a zero outside the unit
  circle (q > 1) takes at most 1/(1 + q), one inside at most 1/(1 − q); the zero inside closest to −1
  takes Re z/(z + q), which rises with θ, and the equation Re z/(z + q) = D has a closed-form root.  Below that θ_r, φ rises, so F rises
  (−asin g rises too): on [0, θ_r] the equation F = π/2 has at most one root.  F(0) ≤ 0, so levels
  π/2 − 2π... are never reached and the root, when F(θ_r) ≥ π/2, is the binding crossover.
* The damper-only loop: −1/G_n/(1 − e^{−jθ}) = −R e^{j(φ + θ/2)}, real and positive where
  φ + θ/2 = π (mod 2π) with value R.  φ + θ/2 rises on [0, θ_rb] (the bound above with D + ½, so
  θ_rb ≥ θ_r) and R rises everywhere, so its first root θ_b gives B_max = R(θ_b)·m/T exactly.  For β < β_max the K root lies in (0, θ_b):
  F(θ_b) > φ(θ_b) − asin cos(θ_b/2) = π/2.

Where a hypothesis fails (complex or positive zeros, no root below θ_r)
the caller falls back to the scan; ``fast_rigid`` returns None then, never a guess.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from models.discretize import RigidZOH
from optim.stability.rigid_kernel import binding_root, k_eq, loop_numbers, re_h

__all__ = ["RigidLoop", "FastRigid", "rigid_loop", "fast_rigid", "fast_beta_max", "bracketed_newton", "MIN_ZERO_GAP"]

_EPS = 2.220446049250313e-16
_HALF_PI = 0.5 * math.pi
#: a zero closer than this to z = −1 (|1 − q|) puts a near-pole of H on the unit circle: scan instead
MIN_ZERO_GAP = 1e-9


@dataclass(frozen=True)
class RigidLoop:
    """The factored loop of the module docstring (dimensionless)."""

    omp: float                        # 1 − p
    p: float
    lead: float                       # A, the numerator's leading coefficient (> 0)
    zeros: tuple[tuple[float, float], ...]   # (q, 1 − q) of each zero −q
    slope: float                      # d + m + ½
    theta_r: float                    # φ rises on [0, θ_r]
    half_pis_at_pi: int               # φ(π) = this·π/2 exactly (used when θ_r = π)
    theta_rb: float                   # φ + θ/2 rises on [0, θ_rb] (θ_rb ≥ θ_r)
    numbers: np.ndarray = field(compare=False, repr=False)   # the loop as optim.stability.rigid_kernel reads it


@lru_cache(maxsize=4096)
def rigid_loop(plant: RigidZOH) -> RigidLoop | None:
    """The factored form of ``plant``, or None when its zeros break the hypotheses (scan instead)."""
    omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    p = 1.0 - omp
    if plant.f == 0.0:
        a, c = plant.f0_numerator()
        if not (a > 0.0):
            return None
        omq = -c / a                                  # N = a(z + q), q = 1 + c/a
        zeros: tuple[tuple[float, float], ...] = ((1.0 - omq, omq),)
        lead, m = a, 0
    else:
        aa, bb, cc = g0p, g1p - p * g0p + phi12 * g0v, phi12 * g1v - p * g1p
        disc = bb * bb - 4.0 * aa * cc
        if not (aa > 0.0 and bb > 0.0 and cc > 0.0 and disc >= 0.0):
            return None                               # complex or non-negative-real zeros
        big = (bb + math.sqrt(disc)) / (2.0 * aa)     # roots −q: q = big and C/(A·big), both > 0
        small = cc / (aa * big)
        zeros = ((big, 1.0 - big), (small, 1.0 - small))
        lead, m = aa, 1
    # f = 0: 1 − q comes from the series of c(δ), accurate down to δ = 0 (q = 1: the zero at −1 of the
    # undamped plant, H(π) infinite); f > 0: from the quadratic, so a zero near −1 is not trusted
    if any(q <= 0.0 or (plant.f > 0.0 and abs(omq) < MIN_ZERO_GAP) for q, omq in zeros):
        return None
    slope = plant.d + m + 0.5
    # the zero inside closest to −1 is taken exactly; any other inside one at its largest, 1/(1 − q) (at π)
    inside = sorted((z for z in zeros if z[0] < 1.0), reverse=True)
    bound = (slope + 1.0 / (1.0 + p) - sum(1.0 / (1.0 + q) for q, _ in zeros if q > 1.0)
             - sum(1.0 / omq for _, omq in inside[1:]))
    n_in = len(inside)
    theta_r = _rising_end(bound, inside[:1], zeros)
    theta_rb = _rising_end(bound + 0.5, inside[:1], zeros)   # φ + θ/2, the damper loop's phase
    if theta_r is None or theta_rb is None:
        return None
    # at θ = π exactly every arg is 0 or π: φ(π) = (d + m + ½ + 1 − n_in)π, in halves of π
    return RigidLoop(omp, p, lead, zeros, slope, theta_r, 2 * (plant.d + m + 1 - n_in) + 1, theta_rb,
                     loop_numbers(plant, omp, p, lead, slope, zeros))


def _rising_end(bound: float, inside, zeros) -> float | None:
    """θ up to which slope − Re z/(z + q) > 0 for the inside zero q (π when it holds everywhere)."""
    bound *= 1.0 - 1e-12                              # a little inside: a bound, never rounded past
    if any(omq == 0.0 for _, omq in zeros):
        return math.pi * (1.0 - 1e-9)                 # H has a pole at π; the tail bounds still hold
    if not inside:
        return math.pi
    q, omq = inside[0]
    if bound <= 1.0 / (1.0 + q):
        return None
    # Re z/(z + q) = D  ⇔  2cos²(θ/2) = (1 − q)(1 − D(1 − q)) / (q(2D − 1))
    rhs = omq * (1.0 - bound * omq) / (q * (2.0 * bound - 1.0))
    if rhs > 0.0:
        return 2.0 * math.acos(min(1.0, math.sqrt(0.5 * rhs)))
    return math.pi


def _parts(L: RigidLoop, t: float) -> tuple[float, float, float, float]:
    """(ψ = φ − π/2, φ', R, R'/R) at θ = t ∈ (0, π].

    ψ, not φ: arg(z − p) = π/2 − atan2(cos θ − p, sin θ), so near a low-frequency crossover of a nearly
    undamped plant ψ is a sum of small terms, each to full relative precision (φ ≈ π/2 + 1e-5 would
    keep only 11 digits of the part that sets θ)."""
    sh, ch = math.sin(0.5 * t), math.cos(0.5 * t)
    st = 2.0 * sh * ch
    re_p = L.omp - 2.0 * sh * sh                    # cos θ − p without cancellation
    den_p = re_p * re_p + st * st
    phi = L.slope * t - math.atan2(re_p, st)
    dphi = L.slope + (L.omp + 2.0 * L.p * sh * sh) / den_p
    dlr = L.p * st / den_p
    mag = math.sqrt(den_p) / L.lead
    for q, omq in L.zeros:
        re_q = 2.0 * ch * ch - omq                  # cos θ + q
        den_q = re_q * re_q + st * st
        phi -= math.atan2(st, re_q)
        dphi -= (omq + 2.0 * q * ch * ch) / den_q
        dlr += q * st / den_q
        mag /= math.sqrt(den_q)
    return phi, dphi, mag, dlr


def _damper_eq(L: RigidLoop, t: float) -> tuple[float, float]:
    """ψ + θ/2 (= π/2 at a damper-loop crossover) and its derivative."""
    psi, dphi, _, _ = _parts(L, t)
    return psi + 0.5 * t, dphi + 0.5


def bracketed_newton(fun, level: float, lo: float, hi: float, x: float, step_rtol: float = 2.0 * _EPS,
                     bracket_rtol: float = 4.0 * _EPS) -> float:
    """The root of the non-decreasing fun(θ) = level in [lo, hi] (fun(lo) < level ≤ fun(hi); fun returns the value
    and its derivative): Newton steps, kept in the bracket (bisection, geometric while the bracket spans decades),
    to a relative step of ``step_rtol`` or a bracket of ``bracket_rtol`` (by default 2 and 4 ulp).  The damper
    loop's root here and the cable brackets (optim.stability.cable_brackets); the rigid K crossovers take its compiled
    form (optim.stability.rigid_kernel), with its early stop under quadratic convergence."""
    for _ in range(200):
        if not (lo < x < hi):
            x = math.sqrt(lo * hi) if lo > 0.0 and hi > 8.0 * lo else 0.5 * (lo + hi)
        fx, dfx = fun(x)
        if fx == level:
            return x
        if fx < level:
            lo = x
        else:
            hi = x
        if hi - lo <= bracket_rtol * hi:
            return x
        step = (fx - level) / dfx if dfx > 0.0 else math.inf
        xn = x - step
        if lo <= xn <= hi and abs(step) <= step_rtol * x:
            return xn   # converged (from one side, hi stays far)
        x = xn
    return x


@dataclass(frozen=True)
class FastRigid:
    """The fast path's answer (dimensionless)."""

    alpha: float
    """α_cr (0 when β ≥ β_max)."""
    theta: float | None
    """θ of the binding crossover (None when α_cr = 0)."""
    beta_max: float | None
    """β_max, when β > 0 (None at β = 0: not needed)."""


def _start(L: RigidLoop, damp: float, level: float, hi: float) -> float:
    """Closed-form start: (d + m + ½)θ + atan(θ/damp) ≈ level for the low-frequency crossover."""
    a = L.slope + 0.5
    x = math.sqrt(damp / a) if damp > 0 else level / a
    if damp > 0 and damp / x > 1.0:
        x = level / (a + 1.0 / damp)
    return min(x, 0.5 * hi)


def _damper_start(L: RigidLoop, hi: float) -> float:
    """Closed-form start: ψ + θ/2 ≈ (d + m + 1)θ − δ/θ at low frequency, = π/2 at θ_b."""
    a = L.slope + 0.5
    x = (_HALF_PI + math.sqrt(_HALF_PI * _HALF_PI + 4.0 * a * L.omp)) / (2.0 * a)
    return min(x, 0.5 * hi)


@lru_cache(maxsize=4096)
def _damper_root(L: RigidLoop) -> tuple[float, float] | None:
    """(θ_b, β_max): the damper-only loop's first crossover, or None when it is past θ_rb.  A property of the
    device's loop alone, cached as rigid_loop is (a design or a study asks K_cr(B) of one device at many B)."""
    tr = L.theta_rb
    # at θ = π exactly: ψ(π) = (half_pis_at_pi − 1)·π/2, so ψ + θ/2 = half_pis_at_pi·π/2
    fb = L.half_pis_at_pi * _HALF_PI if tr == math.pi else _damper_eq(L, tr)[0]
    if fb < _HALF_PI:
        return None
    if tr == math.pi and L.half_pis_at_pi == 1:
        tb = math.pi                          # the Nyquist point: ψ + θ/2 reaches π/2 only there
    else:
        tb = bracketed_newton(lambda t: _damper_eq(L, t), _HALF_PI, 0.0, tr, _damper_start(L, tr))
    return tb, _parts(L, tb)[2]


def fast_beta_max(plant: RigidZOH) -> float | None:
    """β_max (dimensionless) by the fast path, or None where its bounds do not close."""
    L = rigid_loop(plant)
    root = None if L is None else _damper_root(L)
    return None if root is None else root[1]


def fast_rigid(plant: RigidZOH, beta: float, beta_max: float | None = None,
               loop: RigidLoop | None = None) -> FastRigid | None:
    """α_cr(β) and β_max of a rigid plant by the closed-form brackets above; None where they do not close.

    ``beta_max``: the caller's β_max (dimensionless), when it has it; the decision β ≥ β_max then uses it."""
    L = loop if loop is not None else rigid_loop(plant)
    if L is None:
        return None
    if beta > 0.0:
        damper = _damper_root(L)
        if damper is None:
            return None
        tb, rb = damper
        bmax = rb if beta_max is None else beta_max
        if beta >= bmax:
            return FastRigid(0.0, None, bmax)
        hi = min(tb, L.theta_r)                 # F̃ rises on [0, θ_r]; the root is below θ_b
    else:
        bmax, hi = None, L.theta_r
    if hi == math.pi:
        if L.half_pis_at_pi == 1:             # F(π) = π/2 exactly: the binding crossover is Nyquist's
            return FastRigid(re_h(L.numbers, beta, math.pi), math.pi, bmax)
        fk = (L.half_pis_at_pi - 1) * _HALF_PI
    else:
        fk, _ = k_eq(L.numbers, beta, hi)   # compiled _k_eq: the same bits
    if not fk > 0.0:
        return None                           # no K crossover below θ_r (or β_max rounded the other way)
    # bracketed_newton on _k_eq (β = 0: _psi) from the closed-form start, then polish_h: compiled, the same bits
    t, alpha = binding_root(L.numbers, beta, hi, _start(L, L.omp + beta, _HALF_PI, hi))
    return FastRigid(alpha, t, bmax)
