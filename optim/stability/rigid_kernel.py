"""The rigid fast path's scalar solves compiled (numba): the binding crossover and every level below θ_r (issue 20).

The same operations, in the same order, as the Python evaluators they replaced (fast_rigid's until issue 20's
kernels; now the twins in tests/optim/stability/rigid_python.py), so the same bits:
``_k_eq``/``_psi`` (F̃ − π/2 and its slope), ``_h`` (H = −1/G_n + β(e^{−jθ} − 1), with
CPython's complex arithmetic, which numba's complex product and quotient reproduce: Smith's quotient with
CPython's branches), ``bracketed_newton`` with its early stop and ``polish_h``, and ``rigid_levels``' loop over the levels
(its starts, and at β = 0 with a whole-sample delay K = 2·sin(θ/2)·R(θ) where K is not steep).  No ``fastmath``:
LLVM neither reassociates nor fuses a product into an addition here.  tests/optim/stability/test_rigid_kernel.py
holds each compiled function to its Python twin bit for bit on random devices, whole and fractional delays,
B = 0 and B > 0.

Why compiled: the crossover list of a long delay holds one root per 2π of phase (the 200-sample loop of issue 20
has 102), each a bracketed Newton of ~4 evaluations of 4 transcendental functions; in Python each level cost
≈ 2.5 µs (numpy passes over all levels at once, ≈ 250 array operations of ≈ 0.4 µs, did no better below a
hundred levels), compiled ≈ 0.3 µs.  A server computes each analysis after its process slept on the socket,
with the interpreter's caches cold: a compiled loop's few kilobytes of machine code lose less there than the
interpreter's path through a hundred Python functions.

The loop's numbers travel as a flat float array (``loop_numbers``): omp, p, lead, slope, q₁, 1 − q₁, q₂, 1 − q₂,
then the plant's a, c (N = a(z + 1) + c, whole-sample delay) or Φ₁₂, Γ0p, Γ0v, Γ1p, Γ1v (fractional delay), the
whole delay d, and the count of zeros and whether the delay is fractional.

The first call of a process compiles, or loads the compiled code from numba's disk cache (optim.stability.compiled:
beside this file, else NUMBA_CACHE_DIR or the user's cache; none writable: compiled per process); the server's warm-up
makes that call before it says it is ready.
"""

from __future__ import annotations

import math

import numpy as np

from models.discretize import RigidZOH
from optim.stability.compiled import kernel

__all__ = ["loop_numbers", "k_eq", "re_h", "binding_root", "level_roots", "compile_kernels"]

_EPS = 2.220446049250313e-16
_HALF_PI = 0.5 * math.pi
_TWO_PI = 2.0 * math.pi
#: d ln K / d ln θ above which a β = 0 level's K comes from the polish's H (rigid_levels._STEEP)
_STEEP = 6.0

# indices into the loop's numbers
(AT_OMP, AT_P, AT_LEAD, AT_SLOPE, AT_Q1, AT_OMQ1, AT_Q2, AT_OMQ2, AT_A, AT_C, AT_PHI12, AT_G0P, AT_G0V, AT_G1P, AT_G1V,
 AT_D, AT_NZ, AT_FRAC) = range(18)


def loop_numbers(plant: RigidZOH, omp: float, p: float, lead: float, slope: float,
                 zeros: tuple[tuple[float, float], ...]) -> np.ndarray:
    """The flat array of the kernel's numbers for ``plant`` and its factored loop (fast_rigid.RigidLoop's omp, p,
    lead, slope and the (q, 1 − q) of its one or two zeros)."""
    _, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    a, c = plant.f0_numerator() if plant.f == 0.0 else (0.0, 0.0)
    (q1, omq1), *rest = zeros
    q2, omq2 = rest[0] if rest else (0.0, 0.0)
    return np.array([omp, p, lead, slope, q1, omq1, q2, omq2, a, c, phi12, g0p, g0v, g1p, g1v,
                     float(plant.d), float(len(zeros)), 1.0 if plant.f != 0.0 else 0.0])


@kernel
def k_eq(v, beta, t):
    """F̃ − π/2 and its slope at θ = t (β > 0; at β = 0 ψ and φ', the twins' ``_k_eq`` and ``_psi``)."""
    omp, p, slope = v[AT_OMP], v[AT_P], v[AT_SLOPE]
    nz = int(v[AT_NZ])
    sh, ch = math.sin(0.5 * t), math.cos(0.5 * t)
    st = 2.0 * sh * ch
    re_p = omp - 2.0 * sh * sh
    den_p = re_p * re_p + st * st
    phi = slope * t - math.atan2(re_p, st)
    if beta == 0.0:
        dphi = slope + (omp + 2.0 * p * sh * sh) / den_p
        for i in range(nz):
            q, omq = v[AT_Q1 + 2 * i], v[AT_OMQ1 + 2 * i]
            re_q = 2.0 * ch * ch - omq
            phi -= math.atan2(st, re_q)
            dphi -= (omq + 2.0 * q * ch * ch) / (re_q * re_q + st * st)
        return phi, dphi
    dphi = slope + (omp + 2.0 * p * sh * sh) / den_p
    dlr = p * st / den_p
    mag = math.sqrt(den_p) / v[AT_LEAD]
    for i in range(nz):
        q, omq = v[AT_Q1 + 2 * i], v[AT_OMQ1 + 2 * i]
        re_q = 2.0 * ch * ch - omq
        den_q = re_q * re_q + st * st
        phi -= math.atan2(st, re_q)
        dphi -= (omq + 2.0 * q * ch * ch) / den_q
        dlr += q * st / den_q
        mag /= math.sqrt(den_q)
    g = beta * math.cos(0.5 * t) / mag
    if g >= 1.0:
        return phi - _HALF_PI, dphi
    dg = g * (-0.5 * math.tan(0.5 * t) - dlr)
    return phi - math.asin(g), dphi - dg / math.sqrt((1.0 - g) * (1.0 + g))


@kernel
def _h(v, beta, t):
    """H(θ) = −1/G_n + β(e^{−jθ} − 1), as RigidZOH.inverse_response and the scan compute it, CPython's complex
    operations in their order."""
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    z = complex(math.cos(t), st)
    zm1 = complex(-2.0 * sh * sh, st)
    omp = v[AT_OMP]
    if t == math.pi:
        # z = −1 exactly (RigidZOH.inverse_at_nyquist): H(π) real, without sin(π)'s rounding in z + 1
        if v[AT_FRAC] == 0.0:
            num_pi = v[AT_C]
        else:
            num_pi = (v[AT_G0P] - v[AT_G1P]) * (omp - 2.0) + v[AT_PHI12] * (v[AT_G0V] - v[AT_G1V])
        if num_pi != 0.0:        # 0: a zero on −1 (δ = 0), H(π) is a pole: the complex formula's value, as before
            inv_pi = (-1.0 if int(v[AT_D]) % 2 else 1.0) * (-2.0 * (omp - 2.0)) / num_pi
            return complex(-inv_pi - 2.0 * beta * sh * sh, 0.0)
    if v[AT_FRAC] == 0.0:
        num = v[AT_A] * (z + 1.0) + v[AT_C]
    else:
        zinv = 1.0 / z
        num = (v[AT_G0P] + v[AT_G1P] * zinv) * (zm1 + omp) + v[AT_PHI12] * (v[AT_G0V] + v[AT_G1V] * zinv)
    dt = v[AT_D] * t
    inv = zm1 * (zm1 + omp) * complex(math.cos(dt), math.sin(dt)) / num
    return complex(-inv.real - 2.0 * beta * sh * sh, -inv.imag - beta * st)


@kernel
def re_h(v, beta, t):
    """K (dimensionless) of a crossover at θ = t: Re H(θ) by the scan's own formula (RigidZOH.inverse_response).

    Not k(θ) of fast_rigid's docstring (equal at a root), nor 2s(R cos ψ − βs): near β_max K is a small difference
    of O(β) terms, and this form keeps the scan's accuracy there (~4e-14 against the 40-digit reference at
    0.9997·B_max, where the factored form lost ~1.6e-12)."""
    return _h(v, beta, t).real


@kernel
def _polish(v, beta, t):
    """(θ, Re H(θ)) after one secant step on Im H from the root t of F̃, kept where it lowers |Im H|: near β_max K
    moves by ~1e-12 per ulp of θ, and Im H pins θ a few ulp closer than F̃'s sum of arguments does."""
    dh = 64.0 * _EPS * t
    v0 = _h(v, beta, t)
    f0, f1 = v0.imag, _h(v, beta, t + dh).imag
    if f1 == f0 or f0 == 0.0:
        return t, v0.real
    t1 = t - f0 * dh / (f1 - f0)
    if t1 == t:
        return t, v0.real
    if abs(t1 - t) <= 8.0 * _EPS * t and t1 < math.pi:
        v1 = _h(v, beta, t1)
        if abs(v1.imag) < abs(f0):
            return t1, v1.real
    return t, v0.real


@kernel
def _newton(v, beta, level, lo, hi, x, quadratic_slope):
    """fast_rigid.bracketed_newton on F̃ = level (2 ulp step, 4 ulp bracket), and where F̃' ≥ quadratic_slope also
    stopping at the Newton iterate once the steps show quadratic convergence put it within a quarter ulp of the root
    (the step ≤ 1e-10 relative and |step|³/prev² ≤ ε/4 relative), one evaluation before the step falls to an ulp."""
    step_rtol, bracket_rtol = 2.0 * _EPS, 4.0 * _EPS
    prev = math.inf
    for _ in range(200):
        if not (lo < x < hi):
            x = math.sqrt(lo * hi) if lo > 0.0 and hi > 8.0 * lo else 0.5 * (lo + hi)
            prev = math.inf
        fx, dfx = k_eq(v, beta, x)
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
        if lo <= xn <= hi:
            a = abs(step)
            if a <= step_rtol * x or (dfx >= quadratic_slope and a <= 1e-10 * xn
                                      and a * a * a <= 0.25 * _EPS * xn * prev * prev):
                return xn
        prev = step
        x = xn
    return x


@kernel
def binding_root(v, beta, hi, start):
    """fast_rigid's binding crossover: the root of F̃ = π/2 in [0, hi] from ``start``, polished: (θ, α = Re H)."""
    t = _newton(v, beta, 0.0, 0.0, hi, start, math.inf)
    return _polish(v, beta, t)


@kernel
def level_roots(v, beta, n, t0, tr):
    """The roots at the levels 2πk, k = 1…n, in turn (rigid_levels' loop): arrays (θ, α)."""
    theta = np.empty(n)
    alpha = np.empty(n)
    slope = v[AT_SLOPE]
    half_slope, step1 = 0.5 * slope, 2.0 * math.pi / (slope + 0.5)
    whole_undamped = beta == 0.0 and v[AT_NZ] == 1.0
    omp, p, lead, q, omq = v[AT_OMP], v[AT_P], v[AT_LEAD], v[AT_Q1], v[AT_OMQ1]
    r1 = r2 = r3 = t0                                     # the last three roots (levels k − 1, k − 2, k − 3)
    for k in range(1, n + 1):
        lo = r1
        x = lo + step1 if k == 1 else lo + (lo - r2) if k == 2 else 3.0 * (lo - r2) + r3
        mid = 0.5 * (lo + tr)
        if x > mid:
            x = mid
        t = _newton(v, beta, _TWO_PI * k, lo, tr, x, half_slope)
        if whole_undamped:
            # rigid_levels._undamped_whole: K = 2·sin(θ/2)·R(θ) where K is not steep in θ, else the polish
            sh, ch = math.sin(0.5 * t), math.cos(0.5 * t)
            st = 2.0 * sh * ch
            re_p = omp - 2.0 * sh * sh
            re_q = 2.0 * ch * ch - omq
            den_p, den_q = re_p * re_p + st * st, re_q * re_q + st * st
            if t * (0.5 * ch / sh + p * st / den_p + q * st / den_q) <= _STEEP:
                a = 2.0 * sh * (math.sqrt(den_p) / lead) / math.sqrt(den_q)
            else:
                t, a = _polish(v, 0.0, t)
        else:
            t, a = _polish(v, beta, t)
        theta[k - 1] = t
        alpha[k - 1] = a
        r1, r2, r3 = t, r1, r2
    return theta, alpha


def example_loop() -> np.ndarray:
    """A made-up loop's numbers (a whole-sample delay, whose numbers need no plant), to compile the kernels on."""
    v = np.zeros(18)
    v[[AT_OMP, AT_P, AT_LEAD, AT_SLOPE, AT_Q1, AT_OMQ1, AT_A, AT_C, AT_D, AT_NZ]] = [
        0.01, 0.99, 0.5, 2.5, 0.9, 0.1, 0.5, -0.05, 2.0, 1.0]
    return v


def compile_kernels() -> None:
    """Compile every kernel now (or load it from numba's cache), on a made-up loop: a process that calls this
    before it serves answers its first rigid analysis at full speed, where the first call would otherwise pay
    ≈ 0.1 s (cached) to 3 s (compiling)."""
    v = example_loop()
    for beta in (0.0, 1e-3):
        re_h(v, beta, math.pi)
        binding_root(v, beta, 1.0, 0.1)
        level_roots(v, beta, 1, 0.1, 1.0)
