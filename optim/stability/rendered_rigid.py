"""Every real value of a rendered rigid wall's h (optim.stability.rendered) without a scan: the crossings isolated with
a certificate on a trigonometric polynomial, then refined on the accurate h (issue 30, speed).

For a rigid plant 1/G_n = (1 − w)(1 − p w)/(w^{d+1}·M̃(w)), w = z⁻¹, with M̃ = a + (a + c)w (whole-sample delay:
optim.stability.fast_rigid's N = a(z + 1) + c) or A + Bw + Cw² (a fraction f: z·N = Az² + Bz + C), and the velocity
estimate V_n = (1 − w)R(w)/D(w), each of rendered.py's three functions is a ratio of polynomials in w:

    h_K = [−(1 − w)P₁D − Dg(1 − w)(β + μ(1 − w))R] / (Dg·D)
    h_B = [−P₁D − μ·Dg(1 − w)R] / (Dg·R)
    h_M = [−(1 − w)P₁D − α·Dg·D − β·Dg(1 − w)R] / (Dg·(1 − w)²·R)    (α = 0: one factor 1 − w cancels)

with P₁ = 1 − p w and Dg = w^{d+1}M̃.  With h = P/Q, Im h·|Q|² = Im(P(w)·Q(w̄)) = Σ_{k≥1} c_k sin kθ (real
coefficients: c_k = r_{−k} − r_k, r the correlation of P with Q), so Im h = 0 on (0, π) exactly where

    f(θ) = Σ c_k sin kθ / sin θ = Σ c_k U_{k−1}(cos θ) = p(cos θ),

a polynomial p of degree n − 1 in cos θ, written here in Chebyshev-T form (a_j).  (1 − w̄)² = −4 sin²(θ/2)·w̄, so
Q's factor (1 − w)² is replaced by −w (the same sign of Im); Butterworth's R = r₀(1 + w)² likewise by r₀·w
((1 + w̄)² = 4 cos²(θ/2)·w̄).

Completeness (why no crossing is missed): [0, π] is bisected until every piece is either

* free of roots: |f(θ₁)| + |f(θ₂)| − 2E > L₁·(θ₂ − θ₁), L₁ a bound of |f'| on the piece, or
* holds exactly one: f changes sign (|f| > E at both ends) and f' is certified of one sign there
  (|f'(θ₁)| + |f'(θ₂)| − 2E' > L₂·(θ₂ − θ₁), f'(θ₁)f'(θ₂) > 0).

The bounds: f is a cosine polynomial of degree n − 1 with |f| ≤ Σ|a_j| = A, so |f'| ≤ (n − 1)·A (Bernstein) and
|f''| ≤ (n − 1)²·A; near 0 and π, f' = −sin θ·p'(cos θ) with |p'| ≤ Σ j²|a_j| and |p''| ≤ Σ j²(j² − 1)/3·|a_j|
(Markov) give the smaller |f'| ≤ sin θ·Σ j²|a_j| and |f''| ≤ Σ j²|a_j| + sin²θ·Σ j²(j² − 1)/3·|a_j|; each piece takes
the smaller bound.  E bounds the rounding of the coefficients (the convolutions of rounded inputs) and of the
evaluation (Clenshaw, x = cos θ rounded): 16(n + 8)²·ε·Σ (the same sums on absolute values) + ε·Σ j²|a_j|.
Where no piece certifies within the budget (a tangency, a crossing at θ → 0⁺ or at π, a root of Q on the circle,
|f| below the rounding bound everywhere near a root) the answer is None and the caller scans (optim.stability.
crossovers): never a guess.

Each certified root's piece is then a bracket of the accurate h (the expm1 forms of models.discretize.RigidZOH and
models.velocity_filter, compiled), whose sign at both ends must agree with f's (else None); Illinois' regula falsi
refines it to 4 ulp, as optim.stability.crossovers.solve_brackets does.  The direction of the poles at a crossing
(rendered.Passage.outward) is the sign of f' there, certified above; at θ = π it is the sign of f(π) = p(−1).

Speed (issue 30: a filtered K_cr within 10× of today's): everything above runs in one compiled call
(``_crossings``) on the (plant, filter)'s polynomial data, built once and cached (``_parts``); its Python twin,
numpy building the same polynomials on every call, is tests/optim/stability/rendered_rigid_python.py (bit for bit).

Cable plants (``cable_real_crossings``): optim.stability.cable_loop factors a damped cable's loop as
Q = z/(z − 1)/G_n = z^s·Π(z − c_k)/(L·Π(z − ζ_i)), so 1/G_n = (1 − w)·P₁/Dg with P₁ = Π(1 − c_k w) and
Dg = L·w^{s+K−I}·Π(1 − ζ_i w): the form above with longer polynomials, and the same isolation.  The computed zeros
ζ_i carry an error bound (cable_loop's); coefficient by coefficient the product then stays within Π(1 + err/|ζ|)
of the product of absolute values, so that factor, less one, is added to E's relative size.  Each root is refined
on the modal form's 1/G_n (optim.stability.cable_kernel._inv_response, today's cable K_cr's own).  At low damping
a cable's h is a difference of terms many times |h| (the modes cancel, ~θ/δ): the modal form's and the scan's
roundings then differ in the answer's last digits (4e-10 on a random cable with δ ≈ 6e-6), so where the terms
exceed |h| by more than _CABLE_CONDITION at a root, the scan answers, as before.
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

import numpy as np

from models.discretize import RigidZOH, StateSpaceZOH
from models.velocity_filter import Rendering, VelocityTransfer
from optim.stability.cable_kernel import inverse_response as _inv_response
from optim.stability.cable_loop import cable_loop
from optim.stability.compiled import kernel

__all__ = ["LOOP_K", "LOOP_B", "LOOP_M", "rigid_real_crossings", "cable_real_crossings", "compile_kernels", "MAX_PIECES",
           "MAX_DEGREE", "v_zero_at_pi", "equal_form", "circle_zero_angles", "divide_by_one_plus_w",
           "TWO_PI_PIECES"]

LOOP_K, LOOP_B, LOOP_M = 0, 1, 2
#: a cable loop's certified crossings are given up (the scan answers) where h's terms exceed |h| by more than this
#: at a root (random cables with δ ≲ 1e-4: the scan's and the modal form's roundings moved K by up to 4e-10)
_CABLE_CONDITION = 100.0
_NO_MODAL = np.zeros(18, dtype=complex)        # a rigid plant's (unused) modal form: one compiled signature
_NO_MODAL.setflags(write=False)
_EPS = 2.220446049250313e-16
#: pieces of [0, π] examined at most before the certificate gives up (the caller scans)
MAX_PIECES = 4_000
#: p's degree at most (a delay of ~40 samples): beyond it the scan, which is then faster (each piece's Taylor bounds
#: cost O(n²) and a long delay's loop has O(n) crossings: 84 ms certified against 17 ms scanned at 119 samples)
MAX_DEGREE = 48


# ---------------------------------------------------------------- the loop's polynomial data (once per plant, filter)

@lru_cache(maxsize=1024)
def _parts(plant: RigidZOH, velocity: VelocityTransfer) -> tuple:
    """What the compiled driver needs of a (plant, filter), built once: (P₁ = [1, −p], Dg = w^{d+1}·M̃ of the module
    docstring, R, D, Q's replacement for R and P's multiplier in h_B and h_M, the moving average's n (0: another
    kind), whether R has a zero on the circle that neither replacement handles, the plant's numbers for h)."""
    omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    p = 1.0 - omp
    if plant.f == 0.0:
        a, c = plant.f0_numerator()
        mt = np.array([a, a + c])
    else:
        mt = np.array([g0p, g1p - p * g0p + phi12 * g0v, phi12 * g1v - p * g1p])
    dg = np.concatenate([np.zeros(plant.d + 1), mt])
    p1, nums = np.array([1.0, -p]), _numbers(plant)
    for x in (p1, dg, nums):
        x.setflags(write=False)      # cached; and read-only arrays are one compiled signature with the cable's
    _, _, r, d, r_q, p_mul, avg_n, circle, _ = _parts_filter(velocity)
    return p1, dg, r, d, r_q, p_mul, avg_n, circle, nums


@lru_cache(maxsize=1024)
def _parts_filter(velocity: VelocityTransfer) -> tuple:
    """The filter's share of ``_parts``: (None, None, R, D, Q's replacement for R, P's multiplier, n, circle, None)."""
    r, d = np.asarray(velocity.r, dtype=float), np.asarray(velocity.d, dtype=float)
    avg_n, circle = 0, False
    if butter_form(velocity.r):
        r_q, p_mul = np.array([0.0, r[0]]), np.ones(1)       # r₀(1 + w)² → r₀·w: the same sign of Im
    elif velocity.kind == "moving_average":
        r_q, p_mul = _average_q(len(r))
        avg_n = len(r)
    else:
        # a root of R within 1e-6 of the circle: the scan answers h_B, h_M (whose poles circle_zero_angles decides)
        circle = _circle_zeros(velocity.r)
        r_q, p_mul = r, np.ones(1)
    for x in (r, d, r_q, p_mul):
        x.setflags(write=False)
    return None, None, r, d, r_q, p_mul, avg_n, circle, None


@lru_cache(maxsize=1024)
def v_zero_at_pi(velocity: VelocityTransfer) -> bool:
    """V(e^{jπ}) = 0 exactly: R(−1) = Σ (−1)^k r_k = 0 in rational arithmetic on the filter's coefficients (every
    float is a rational; D(−1) ≠ 0, D's roots lying inside the circle).  True for every order-2 Butterworth
    (scipy's b = b₀·(1, 2, 1) exactly: checked on 20,000 random cutoffs) and every moving average of even length
    (n equal coefficients 1/n), false for the other kinds; a transfer function's R decides for itself.  Where true,
    θ = π is a pole of h_B and h_M (V_n and A_n vanish, −1/G_n(π) does not): no finite gain puts a closed-loop pole
    at z = −1 (1 + C·G there is 1 + K·G(−1), whatever B and M), so π is no crossing of those loops."""
    return sum((Fraction(c) if k % 2 == 0 else -Fraction(c) for k, c in enumerate(velocity.r)), Fraction(0)) == 0


def equal_form(velocity: VelocityTransfer) -> tuple[int, float]:
    """(n, c) when R = c·(1 + w + … + w^{n−1}) exactly, n ≥ 2 (every moving average, and a transfer function whose
    R's coefficients are all equal): then V_n = (1 − w)R/D = c·(1 − wⁿ)/D, whose zeros on the circle are exactly
    e^{2πjk/n}, k = 1 … n − 1; (0, 0.0) otherwise."""
    r = velocity.r
    if len(r) >= 2 and r[0] != 0.0 and all(c == r[0] for c in r):
        return len(r), float(r[0])
    return 0, 0.0


@lru_cache(maxsize=1024)
def circle_zero_angles(velocity: VelocityTransfer) -> tuple[float, ...] | None:
    """θ ∈ (0, π) of V's zeros on the unit circle other than z = 1 and z = −1 (``v_zero_at_pi`` decides π), decided
    exactly: 2πk/n (rounded once) for R = c·(1 + … + w^{n−1}) (``equal_form``); () where R has no zero on the circle
    but z = −1 (``_no_other_circle_zero``: R's gcd with its reversal is (1 + w)^m, modulo a prime); None where that is
    not decided (R shares another factor with its reversal: a zero on the circle, or a pair ζ, 1/ζ).  Each angle is a
    pole of h_B and h_M (V, A vanish there; −1/G_n does not), never a crossing."""
    n, _ = equal_form(velocity)
    if n:
        return average_zero_angles(n)
    return () if _no_other_circle_zero(velocity.r) else None


#: 2π in three pieces (Cody–Waite): the first two of 32 bits, so m·piece is exact for m < 2²¹ (V's 1 − wⁿ, here
#: and in optim.stability.rendered)
TWO_PI_PIECES = (6.2831853069365025, 2.4308402025215864e-10, 8.089064995183803e-21)
_TWO_PI_1, _TWO_PI_2, _TWO_PI_3 = TWO_PI_PIECES

#: primes for the modular gcd (2⁶¹ − 1 and 2³¹ − 1)
_PRIMES = (2305843009213693951, 2147483647)


def _no_other_circle_zero(r: tuple[float, ...]) -> bool:
    """True when every root of R on the unit circle is −1: deg gcd(R, R̃) = m (R̃ the reversed R, m the multiplicity
    of −1, counted in rational arithmetic), with the gcd taken modulo a prime p dividing neither end coefficient
    (then deg gcd over ℚ ≤ deg gcd mod p, and (1 + w)^m divides both).  A zero ζ ≠ ±1 on the circle of a real R is
    also one of R̃ (R̃(ζ) = ζ^N·R(1/ζ) = ζ^N·R(ζ̄) = 0), so it would raise the gcd's degree.  False: not decided."""
    q = [Fraction(c) for c in r]
    while q and q[0] == 0:
        q = q[1:]                                  # a factor w^j: no zero on the circle
    if len(q) < 2:
        return True
    scale = 1
    for c in q:
        scale = scale * c.denominator // math.gcd(scale, c.denominator)
    ints = [int(c * scale) for c in q]
    m, _ = divide_by_one_plus_w(q)
    for p in _PRIMES:
        if ints[0] % p == 0 or ints[-1] % p == 0:
            continue
        if _gcd_degree_mod(ints, ints[::-1], p) == m:
            return True
    return False


def divide_by_one_plus_w(q: list[Fraction]) -> tuple[int, list[Fraction]]:
    """(m, Q) with Σ q_k w^k = (1 + w)^m·Q(w), Q(−1) ≠ 0: synthetic division by w = −1 in rational arithmetic
    (ascending coefficients), repeated while the remainder is exactly 0."""
    m = 0
    while len(q) > 1:
        out = [q[0]]
        for c in q[1:-1]:
            out.append(c - out[-1])
        if q[-1] - out[-1] != 0:
            break
        q, m = out, m + 1
    return m, q


def _gcd_degree_mod(a: list[int], b: list[int], p: int) -> int:
    """deg gcd(a, b) over ℤ/p (ascending coefficients; Euclid on the descending lists)."""
    def trim(x: list[int]) -> list[int]:
        x = [c % p for c in x]
        while x and x[0] == 0:
            x = x[1:]
        return x
    x, y = trim(a[::-1]), trim(b[::-1])
    while y:
        inv = pow(y[0], p - 2, p)
        while len(x) >= len(y) and x:
            f = x[0] * inv % p
            x = trim([xi - f * yi for xi, yi in zip(x, y + [0] * (len(x) - len(y)))])
        x, y = y, x
    return len(x) - 1


def butter_form(r: tuple[float, ...]) -> bool:
    """R = r₀(1 + w)² exactly (scipy's second-order Butterworth numerator)."""
    return len(r) == 3 and r[1] == 2.0 * r[0] and r[2] == r[0] and r[0] != 0.0


def _average_q(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(Q's replacement for R, P's multiplier) of an n-sample moving average, R = (1 + w + … + w^{n−1})/n: for even
    n, R = (1 + w)·R'(w) with R' = (1 + w² + … + w^{n−2})/n, and P·(1 + w) over R'·(1 + w)² has Im of the same sign
    as P over R; (1 + w)² → w as for Butterworth.  The other zeros, e^{2πjk/n}, stay (their pieces are dropped)."""
    if n % 2:
        return np.full(n, 1.0 / n), np.ones(1)
    rp = np.zeros(n - 1)
    rp[::2] = 1.0 / n
    return np.concatenate([[0.0], rp]), np.ones(2)


def average_zero_angles(n: int) -> tuple[float, ...]:
    """θ ∈ (0, π) of an n-sample average's zeros on the circle, 2πk/n (π, for even n, is divided out)."""
    return tuple(2.0 * math.pi * k / n for k in range(1, (n + 1) // 2))


def _circle_zeros(r: tuple[float, ...]) -> bool:
    if len(r) < 2:
        return False
    return bool(np.any(np.abs(np.abs(np.roots(np.asarray(r[::-1]))) - 1.0) < 1e-6))


def _numbers(plant: RigidZOH) -> np.ndarray:
    """(1 − p, a, c, Φ₁₂, Γ0p, Γ0v, Γ1p, Γ1v, d, fractional, has Nyquist value, the value, 0: rigid): _h's
    ``nums``."""
    omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    a, c = plant.f0_numerator()
    nyq = plant.inverse_at_nyquist()
    return np.array([omp, a, c, phi12, g0p, g0v, g1p, g1v, float(plant.d), 1.0 if plant.f > 0.0 else 0.0,
                     0.0 if nyq is None else 1.0, 0.0 if nyq is None else nyq, 0.0])


# ---------------------------------------------------------------- the polynomials (compiled, once per call)

@kernel
def _conv(a, b):
    """numpy.convolve(a, b): out[k] = Σ_i a[i]·b[k − i]."""
    out = np.zeros(a.size + b.size - 1)
    for i in range(a.size):
        for j in range(b.size):
            out[i + j] += a[i] * b[j]
    return out


@kernel
def _add(a, b, sa, sb):
    """sa·a + sb·b (sa, sb = ±1), the shorter one padded with zeros."""
    if a.size < b.size:
        a, b, sa, sb = b, a, sb, sa
    out = np.empty(a.size)
    for i in range(a.size):
        out[i] = sa * a[i]
    for i in range(b.size):
        out[i] += sb * b[i]
    return out


@kernel
def _loop_polys(loop, alpha, beta, mu, p1, dg, r, d, r_q, p_mul, absolute):
    """(P, Q_s) of the loop: Q_s has Q's sign of Im (module docstring); with ``absolute`` every coefficient and every
    term taken positive (the sums that bound the rounding)."""
    omw = np.array([1.0, -1.0])
    sgn = -1.0                 # P's terms enter negated (module docstring), or all positive with ``absolute``
    if absolute:
        p1, dg, r, d, r_q, omw = np.abs(p1), np.abs(dg), np.abs(r), np.abs(d), np.abs(r_q), np.abs(omw)
        alpha, beta, mu = abs(alpha), abs(beta), abs(mu)
        sgn = 1.0
    if loop == 0:
        ctrl = np.array([beta + mu, mu * omw[1]])
        a1 = _conv(_conv(omw, p1), d)
        a2 = _conv(_conv(_conv(dg, omw), ctrl), r)
        return _add(a1, a2, sgn, sgn), _conv(dg, d)
    if loop == 1:
        a1 = _conv(p1, d)
        a2 = mu * _conv(_conv(dg, omw), r)
        return _conv(_add(a1, a2, sgn, sgn), p_mul), _conv(dg, r_q)
    a1 = _conv(p1, d)
    a3 = beta * _conv(dg, r)
    if alpha == 0.0:
        return _conv(_add(a1, a3, sgn, sgn), p_mul), _conv(_conv(dg, omw), r_q)
    a1 = _conv(omw, a1)
    a2 = alpha * _conv(dg, d)
    a3 = _conv(omw, a3)
    P = _add(_add(a1, a2, sgn, sgn), a3, 1.0, sgn)
    return _conv(P, p_mul), _conv(_conv(dg, np.array([0.0, sgn])), r_q)


@kernel
def _sine_coefficients(P, Q, absolute):
    """c_1..c_n: Im(P(w)·Q(w̄)) = Σ c_k sin kθ, w = e^{−jθ} (|c|'s bound with ``absolute``)."""
    r = _conv(P, Q[::-1])          # r[i] is the coefficient of w^(i − (len(Q) − 1))
    zero = Q.size - 1
    n = max(zero, r.size - 1 - zero)
    c = np.zeros(n)
    for k in range(1, n + 1):
        pos = r[zero + k] if zero + k < r.size else 0.0
        neg = r[zero - k] if zero - k >= 0 else 0.0
        c[k - 1] = neg + pos if absolute else neg - pos
    return c


@kernel
def _chebyshev_t(c):
    """a_j with Σ c_k U_{k−1}(x) = Σ a_j T_j(x): U_m = 2(T_m + T_{m−2} + …) (+ T₀ once for m even)."""
    n = c.size
    a = np.zeros(max(n, 1))
    for k in range(1, n + 1):
        m = k - 1
        j = m
        while j > 0:
            a[j] += 2.0 * c[k - 1]
            j -= 2
        if m % 2 == 0:
            a[0] += c[k - 1]
    return a


@kernel
def _taylor_table(a):
    """Row k: the Chebyshev series of p^{(k)}/k! (p = Σ a_j T_j), by c'_j = c'_{j+2} + 2(j + 1)c_{j+1}, c'_0 halved
    (numpy.polynomial.chebyshev.chebder's recurrence), divided by k."""
    n = a.size
    dk = np.zeros((n, n))
    dk[0, :] = a
    for k in range(1, n):
        prev = dk[k - 1]
        m = n - k                        # the derivative's length
        for j in range(m - 1, -1, -1):
            nxt = dk[k, j + 2] if j + 2 < m else 0.0
            dk[k, j] = nxt + 2.0 * (j + 1) * prev[j + 1]
        dk[k, 0] *= 0.5
        for j in range(m):
            dk[k, j] /= k
    return dk


# ---------------------------------------------------------------- compiled kernels

@kernel
def _clenshaw(a, x):
    """Σ a_j T_j(x)."""
    b1 = 0.0
    b2 = 0.0
    for j in range(a.size - 1, 0, -1):
        b0 = 2.0 * x * b1 - b2 + a[j]
        b2 = b1
        b1 = b0
    return x * b1 - b2 + a[0]


@kernel
def _isolate(dk, err, out, max_pieces):
    """Certified isolation of the real roots of p on [−1, 1] (module docstring): the pieces holding exactly one root
    written to ``out`` (rows θ₁ < θ₂ = acos of the piece's ends, p at θ₁ and θ₂, p' at the centre), from θ = 0
    up; −1 where the certificate fails.  dk[k] is the Chebyshev series of p^{(k)}/k!, err[k] bounds its rounding:
    on a piece of centre m and half-width ρ, |p(x) − p(m)| ≤ Σ_{k≥1} (|t_k| + err_k)ρ^k (t_k = p^{(k)}(m)/k!,
    exact: p is a polynomial), and likewise for p'."""
    n = dk.shape[0]
    stack = np.empty((400, 4))
    t = np.empty(n)
    stack[0, 0] = -1.0
    stack[0, 1] = 1.0
    stack[0, 2] = _clenshaw(dk[0], -1.0)
    stack[0, 3] = _clenshaw(dk[0], 1.0)
    e0 = err[0]
    if not (abs(stack[0, 2]) > e0 and abs(stack[0, 3]) > e0):
        return -1
    top = 1
    found = 0
    pieces = 0
    while top > 0:
        top -= 1
        x1 = stack[top, 0]
        x2 = stack[top, 1]
        p1 = stack[top, 2]
        p2 = stack[top, 3]
        pieces += 1
        if pieces > max_pieces:
            return -2
        m = 0.5 * (x1 + x2)
        rho = 0.5 * (x2 - x1)
        for k in range(n):
            t[k] = _clenshaw(dk[k], m)
        # zero-free?
        bound = 0.0
        rk = 1.0
        for k in range(1, n):
            rk *= rho
            bound += (abs(t[k]) + err[k]) * rk
        if abs(t[0]) - e0 > bound:
            continue
        # a root's piece never touches θ = 0 or π (h there is 0 or the Nyquist value): bisect it off the ends
        if p1 * p2 < 0.0 and abs(p1) > e0 and abs(p2) > e0 and n > 1 and x1 > -1.0 and x2 < 1.0:
            dbound = 0.0
            rk = 1.0
            for k in range(2, n):
                rk *= rho
                dbound += k * (abs(t[k]) + err[k]) * rk
            if abs(t[1]) - err[1] > dbound:
                if found >= out.shape[0]:
                    return -1
                out[found, 0] = math.acos(x2)
                out[found, 1] = math.acos(x1)
                out[found, 2] = p2
                out[found, 3] = p1
                out[found, 4] = t[1]
                found += 1
                continue
        if rho <= 1e-16 or top + 2 > stack.shape[0]:
            return -3
        # split a little off the centre: a root at a symmetric point (x = 0: the average's e^{±jπ/2}) would sit on
        # both halves' ends, where |p| ≤ E never certifies
        xs = x1 + 0.4812 * (x2 - x1)
        pm = _clenshaw(dk[0], xs)
        # the half nearer x = 1 (lower θ) last: it comes off the stack first
        stack[top, 0] = x1
        stack[top, 1] = xs
        stack[top, 2] = p1
        stack[top, 3] = pm
        stack[top + 1, 0] = xs
        stack[top + 1, 1] = x2
        stack[top + 1, 2] = pm
        stack[top + 1, 3] = p2
        top += 2
    return found


@kernel
def _poly_w(c, w):
    out = complex(c[c.size - 1], 0.0)
    for i in range(c.size - 2, -1, -1):
        out = out * w + c[i]
    return out


@kernel
def _equal(r):
    """R = c·(1 + w + … + w^{n−1}), n ≥ 2 (``equal_form``)."""
    if r.size < 2 or r[0] == 0.0:
        return False
    for i in range(1, r.size):
        if r[i] != r[0]:
            return False
    return True


@kernel
def _one_minus_w_power(n, theta):
    """1 − e^{−jnθ} = 2 sin²(r/2) + j sin r, r = nθ − 2πm reduced in extended precision (as
    optim.stability.rendered._one_minus_w_power: Veltkamp's split of θ, 2π in three pieces, Sterbenz)."""
    split = theta * 134217729.0
    t1 = split - (split - theta)
    t2 = theta - t1
    m = float(round(n * theta / (2.0 * math.pi)))
    r = (((n * t1 - m * _TWO_PI_1) + n * t2) - m * _TWO_PI_2) - m * _TWO_PI_3
    s = math.sin(0.5 * r)
    return complex(2.0 * s * s, math.sin(r))


@kernel
def _h(theta, loop, nums, modal, r, dd, alpha, beta, mu):
    """The loop's h(θ), accurate (models.discretize.RigidZOH.inverse_response, models.velocity_filter):
    nums = (1 − p, a, c, Φ₁₂, Γ0p, Γ0v, Γ1p, Γ1v, d, fractional, has Nyquist value, the value, cable); a cable's
    1/G_n is its modal form's (``modal``: optim.stability.cable_kernel._inv_response, the cable K_cr's own).  nan
    where a division is by 0 (a zero of the plant's numerator, of D, or of V or A on the circle for h_B, h_M).  V is
    c(1 − wⁿ)/D where R's coefficients are all equal (a moving average: ``_one_minus_w_power``, accurate next to
    its zeros 2πk/n, as optim.stability.rendered.velocity_response), else (1 − w)R/D by Horner."""
    nan = complex(math.nan, math.nan)
    omp = nums[0]
    s = math.sin(0.5 * theta)
    ch = math.cos(0.5 * theta)
    st = math.sin(theta)
    ct = math.cos(theta)
    zm1 = complex(-2.0 * s * s, st)
    den = zm1 * (zm1 + omp)
    if nums[12] != 0.0:
        num = complex(1.0, 0.0)
        den = _inv_response(modal, nums[8], theta)
    elif nums[9] == 0.0:
        num = nums[1] * complex(2.0 * ch * ch, st) + nums[2]
    else:
        zinv = complex(ct, -st)
        num = (nums[4] + nums[6] * zinv) * (zm1 + omp) + nums[3] * (nums[5] + nums[7] * zinv)
    if num == 0.0:
        return nan
    dth = nums[8] * theta
    inv = den if nums[12] != 0.0 else den * complex(math.cos(dth), math.sin(dth)) / num
    if theta == math.pi and nums[10] != 0.0:
        inv = complex(nums[11], 0.0)
    w = complex(ct, -st)
    omw = complex(2.0 * s * s, st)
    dv = _poly_w(dd, w)
    if dv == 0.0:
        return nan
    if _equal(r):
        v = r[0] * _one_minus_w_power(r.size, theta) / dv        # c(1 − wⁿ)/D: accurate next to 2πk/n
    else:
        v = omw * _poly_w(r, w) / dv
    acc = v * omw
    if loop == 0:
        return -inv - beta * v - mu * acc
    if loop == 1:
        return (-inv - mu * acc) / v if v != 0.0 else nan
    return (-inv - alpha - beta * v) / acc if acc != 0.0 else nan


@kernel
def _refine(pieces, count, loop, nums, modal, r, dd, alpha, beta, mu, out):
    """Each piece's root of Im h to 4 ulp (Illinois, a bisection every 4th step): rows θ, Re h; False where the
    accurate h's sign at an end disagrees with f's.  (Started nearer, at the polynomial's Newton root, it took a
    third fewer evaluations but moved an ill-conditioned K_cr by 5e-12: the whole piece is kept.)"""
    eps = 2.220446049250313e-16
    for i in range(count):
        a = pieces[i, 0]
        b = pieces[i, 1]
        fa = _h(a, loop, nums, modal, r, dd, alpha, beta, mu).imag
        fb = _h(b, loop, nums, modal, r, dd, alpha, beta, mu).imag
        if not (fa * pieces[i, 2] > 0.0 and fb * pieces[i, 3] > 0.0):     # (nan: False)
            return False
        side = 0
        for it in range(200):
            if abs(b - a) <= 4.0 * eps * max(abs(a), abs(b)):
                break
            lo = min(a, b)
            hi = max(a, b)
            mid = 0.5 * (a + b)
            x = b - fb * (b - a) / (fb - fa) if fb != fa else mid
            m = 2.0 * eps * hi
            if not (lo <= x <= hi) or it % 4 == 3:
                x = mid
            elif x - lo < m:
                x = min(lo + m, mid)
            elif hi - x < m:
                x = max(hi - m, mid)
            fx = _h(x, loop, nums, modal, r, dd, alpha, beta, mu).imag
            if fx != fx:
                return False             # a division by 0 in h: not certified
            if fx == 0.0:
                a = x
                b = x
                fa = 0.0
                fb = 0.0
                break
            if (fx > 0.0) == (fa > 0.0):
                if side == 1:
                    fb = fb / 2.0
                a = x
                fa = fx
                side = 1
            else:
                if side == -1:
                    fa = fa / 2.0
                b = x
                fb = fx
                side = -1
        t = a if abs(fa) <= abs(fb) else b
        out[i, 0] = t
        out[i, 1] = _h(t, loop, nums, modal, r, dd, alpha, beta, mu).real
    return True


@kernel
def _cable_condition(theta, loop, nums, modal, r, dd, alpha, beta, mu):
    """How many times larger than |h| the terms are that make a cable loop's h at θ (the modal sum of G_n, then h's
    own terms): h's rounding is about this times ε (the cable's modal form cancels between its modes, ~θ/δ)."""
    sh = math.sin(0.5 * theta)
    st = math.sin(theta)
    zm1 = complex(-2.0 * sh * sh, st)
    zinv = complex(math.cos(theta), -st)
    acc_e = 0j
    acc_c = 0j
    mag_e = 0.0
    mag_c = 0.0
    for i in range(3):
        lam, r0, r1, e12, c2 = modal[5 * i], modal[5 * i + 1], modal[5 * i + 2], modal[5 * i + 3], modal[5 * i + 4]
        y = (r0 + zinv * r1) / (zm1 - lam)
        acc_e += y * e12
        acc_c += y * c2
        mag_e += abs(y * e12)
        mag_c += abs(y * c2)
    c1, g0_1, g1_1 = modal[15], modal[16], modal[17]
    x1 = (g0_1 + zinv * g1_1 + acc_e) / zm1
    mag_x1 = (abs(g0_1) + abs(g1_1) + mag_e) / abs(zm1)
    g = c1 * x1 + acc_c
    kappa_g = (abs(c1) * mag_x1 + mag_c) / abs(g)
    h = _h(theta, loop, nums, modal, r, dd, alpha, beta, mu)
    inv = 1.0 / abs(g)
    w = complex(math.cos(theta), -st)
    omw = complex(2.0 * sh * sh, st)
    v = abs(omw * _poly_w(r, w) / _poly_w(dd, w))
    acc = v * abs(omw)
    if loop == 0:
        terms = inv * kappa_g + abs(beta) * v + abs(mu) * acc
        return terms / abs(h)
    if loop == 1:
        return (inv * kappa_g + abs(mu) * acc) / (abs(h) * v)
    return (inv * kappa_g + abs(alpha) + abs(beta) * v) / (abs(h) * acc)


@kernel
def _crossings(loop, alpha, beta, mu, p1, dg, r, d, r_q, p_mul, avg_n, nums, modal, pad, max_pieces, max_degree,
               pole_at_pi):
    """rigid_real_crossings in one compiled call: (count, rows θ, h(θ), outward), count −1 where the certificate
    does not close (the caller scans).  ``pad``: the relative error of the plant's polynomial coefficients beyond
    their rounding (a cable's computed zeros), added to every bound.  ``pole_at_pi``: θ = π is a pole of h (V(π) = 0
    exactly, ``v_zero_at_pi``, on h_B or h_M), never listed (h's rounding there is no gain)."""
    none = np.empty((0, 3))
    P, Q = _loop_polys(loop, alpha, beta, mu, p1, dg, r, d, r_q, p_mul, False)
    Pa, Qa = _loop_polys(loop, alpha, beta, mu, p1, dg, r, d, r_q, p_mul, True)
    a = _chebyshev_t(_sine_coefficients(P, Q, False))
    aabs = _chebyshev_t(_sine_coefficients(Pa, Qa, True))
    n = a.size
    big = 0.0
    for j in range(n):
        big += aabs[j]
    if not (big > 0.0 and math.isfinite(big)) or n > max_degree:
        return -1, none
    dk = _taylor_table(a)
    dkabs = _taylor_table(aabs)          # every term positive: a bound of each |coefficient|
    err = np.empty(n)
    scale = 16.0 * (n + 8) ** 2 * 2.220446049250313e-16 + pad
    for k in range(n):
        row = 0.0
        for j in range(n):
            row += dkabs[k, j]
        err[k] = scale * row
    if n > 1:
        slope = 0.0
        for j in range(n):
            slope += dkabs[1, j]
        err[0] += 2.220446049250313e-16 * slope       # x = cos θ rounded: |p'|·ε
    for k in range(n):
        if not math.isfinite(err[k]):
            return -1, none
    pieces = np.empty((n + 2, 5))
    count = _isolate(dk, err, pieces, max_pieces)
    if count < 0:
        return -1, none
    if loop != 0 and avg_n > 0:
        # a zero of R on the circle is a pole of h_B, h_M: its piece (the one root there is that pole) is dropped
        kept = 0
        for i in range(count):
            t1 = pieces[i, 0]
            t2 = pieces[i, 1]
            inside = False
            for k in range(1, (avg_n + 1) // 2):
                q = 2.0 * math.pi * k / avg_n
                if t1 <= q <= t2:
                    if abs(q - t1) <= 1e-12 * q or abs(t2 - q) <= 1e-12 * q:
                        return -1, none
                    inside = True
            if not inside:
                pieces[kept, :] = pieces[i, :]
                kept += 1
        count = kept
    roots = np.empty((max(count, 1), 2))
    if count and not _refine(pieces, count, loop, nums, modal, r, d, alpha, beta, mu, roots):
        return -1, none
    if nums[12] != 0.0:
        # a cable's h is a difference of much larger terms at low damping: where its rounding could move a root's
        # value past what the scan's evaluation gives (they differ in the last bits), the scan answers
        for i in range(count):
            if not _cable_condition(roots[i, 0], loop, nums, modal, r, d, alpha, beta, mu) <= _CABLE_CONDITION:
                return -1, none
    out = np.empty((count + 1, 3))
    found = 0
    for i in range(count):
        v = roots[i, 1]
        if math.isfinite(v) and abs(v) < 1e250 and v != 0.0:
            out[found, 0] = roots[i, 0]
            out[found, 1] = v
            # f'(θ) = −sin θ·p'(cos θ): Im h rises through the root where p' < 0
            out[found, 2] = 2.0 if pieces[i, 4] < 0.0 else -2.0
            found += 1
    if pole_at_pi:
        return found, out
    v_pi = _h(math.pi, loop, nums, modal, r, d, alpha, beta, mu).real
    if math.isfinite(v_pi) and v_pi != 0.0 and abs(v_pi) < 1e250:
        out[found, 0] = math.pi
        out[found, 1] = v_pi
        out[found, 2] = 1.0 if _clenshaw(a, -1.0) < 0.0 else -1.0
        found += 1
    return found, out


def rigid_real_crossings(plant: RigidZOH, rendering: Rendering, loop: int, alpha: float, beta: float,
                         mu: float) -> list[tuple[float, float, int]] | None:
    """Every θ ∈ (0, π] where the loop's h is real (module docstring), as (θ, h(θ), outward) by θ: outward +2/−2 for
    a pair leaving/entering as the moving gain rises (the sign of d Im h/dθ), ±1 at θ = π; None where the
    certificate does not close (the caller scans).  The Nyquist point is listed when h(π) is finite and non-zero, and
    never on h_B, h_M where V(π) = 0 exactly (``v_zero_at_pi``: a pole of h there).  One compiled call (``_crossings``) on the (plant, filter)'s polynomial data, built once (``_parts``)."""
    if plant.delta == 0.0:
        return None                                   # M̃ vanishes at w = −1: a pole of h at π
    p1, dg, r, d, r_q, p_mul, avg_n, circle, nums = _parts(plant, rendering.velocity)
    if circle and loop != LOOP_K:
        return None                          # a zero of R on the circle: a pole of h_B, h_M there
    count, out = _crossings(loop, float(alpha), float(beta), float(mu), p1, dg, r, d, r_q, p_mul, avg_n, nums,
                            _NO_MODAL, 0.0, MAX_PIECES, MAX_DEGREE,
                            loop != LOOP_K and v_zero_at_pi(rendering.velocity))
    if count < 0:
        return None
    return [(t, v, int(o)) for t, v, o in out[:count].tolist()]


def _cable_parts(plant: StateSpaceZOH, velocity: VelocityTransfer) -> tuple | None:
    """``_cable_parts_uncached``, kept with the sampled plant per filter (as cable_loop keeps the factored loop)."""
    key = ("rendered_parts", velocity)
    cache = plant._cache
    if key not in cache:
        cache[key] = _cable_parts_uncached(plant, velocity)
    return cache[key]


def _cable_parts_uncached(plant: StateSpaceZOH, velocity: VelocityTransfer) -> tuple | None:
    """``_parts`` of a damped cable plant from its factored loop (optim.stability.cable_loop: Q = z/(z − 1)/G_n =
    z^s·Π(z − c_k)/(L·Π(z − ζ_i))), so 1/G_n = (1 − w)·P₁/Dg with P₁ = Π(1 − c_k w) and Dg = L·w^{s+K−I}·Π(1 − ζ_i w)
    (w = z⁻¹, K poles c_k, I zeros ζ_i): the rigid form with longer polynomials.  Also the modal form (h's
    accurate 1/G_n) and the relative error of the coefficients, Π(1 + err_i/|ζ_i|) − 1 (each computed zero's error
    bound, cable_loop's): coefficient by coefficient the perturbed product stays within that factor of the product
    of the absolute values.  None where the loop is not factored (the caller scans)."""
    loop = cable_loop(plant)
    if loop is None:
        return None
    poles = [f for f in loop.factors if f.sign > 0]
    zeros = [f for f in loop.factors if f.sign < 0]
    shift = loop.s + len(poles) - len(zeros)
    if shift < 0:
        return None
    p1c = np.ones(1, dtype=complex)
    for f in poles:
        p1c = np.convolve(p1c, np.array([1.0, -f.c]))
    dgc = np.ones(1, dtype=complex)
    for f in zeros:
        dgc = np.convolve(dgc, np.array([1.0, -f.c]))
    lead = loop.lead_abs if loop.lead_arg == 0.0 else -loop.lead_abs
    p1 = p1c.real.copy()
    dg = np.concatenate([np.zeros(shift), lead * dgc.real])
    pad = 1.0
    for f in loop.factors:
        pad *= 1.0 + (f.err + 2.0 * _EPS * f.mag) / f.mag
    pad -= 1.0
    imag = float(np.max(np.abs(p1c.imag))) + float(np.max(np.abs(dgc.imag)))
    if not (math.isfinite(pad) and pad < 1e-6 and imag <= 1e-12 * (float(np.max(np.abs(p1c.real)))
                                                                    + float(np.max(np.abs(dgc.real))))):
        return None                  # the conjugate pairs did not cancel (an unpaired complex factor)
    _, _, r, d, r_q, p_mul, avg_n, circle, _ = _parts_filter(velocity)
    modes, c1, g0_1, g1_1 = loop.modal
    modal = np.array([v for mode in modes for v in mode] + [c1, g0_1, g1_1], dtype=complex)
    nums = np.zeros(13)
    nums[8] = float(loop.d)
    nums[12] = 1.0
    for x in (p1, dg, modal, nums):
        x.setflags(write=False)
    return p1, dg, r, d, r_q, p_mul, avg_n, circle, nums, modal, pad


def cable_real_crossings(plant: StateSpaceZOH, rendering: Rendering, loop: int, alpha: float, beta: float,
                         mu: float) -> list[tuple[float, float, int]] | None:
    """rigid_real_crossings for a damped cable plant (``_cable_parts``): the same certified isolation of the real
    values of h, refined on the modal form's 1/G_n; None where the loop is not factored or the certificate does
    not close (the caller scans)."""
    parts = _cable_parts(plant, rendering.velocity)
    if parts is None:
        return None
    p1, dg, r, d, r_q, p_mul, avg_n, circle, nums, modal, pad = parts
    if circle and loop != LOOP_K:
        return None
    count, out = _crossings(loop, float(alpha), float(beta), float(mu), p1, dg, r, d, r_q, p_mul, avg_n, nums,
                            modal, pad, MAX_PIECES, MAX_DEGREE, loop != LOOP_K and v_zero_at_pi(rendering.velocity))
    if count < 0:
        return None
    return [(t, v, int(o)) for t, v, o in out[:count].tolist()]


def compile_kernels() -> None:
    """Compile (or load from numba's cache) this module's kernels: one call on a small loop."""
    from models.velocity_filter import DEFAULT_VELOCITY
    rigid_real_crossings(RigidZOH(delta=1e-3, d=1), Rendering(DEFAULT_VELOCITY, 0.0), LOOP_K, 0.0, 0.1, 0.0)
