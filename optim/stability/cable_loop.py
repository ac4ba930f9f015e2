"""The cable loop factored from its modal form (issue 20), for the cable brackets (optim.stability.cable_brackets).

With the modal form of models.discretize.StateSpaceZOH (an exact integrator and modes λ, in w = z − 1) the loop is
G_n(z) = L·Π(z − ζ_i) / ((z − 1)·Π(z − c_k)) · z^{−d−m}, c_k = 1 + λ_k; the ζ_i are the roots of the numerator
polynomial in w (computed: each carries an error estimate that every bound allows for), the c_k the modes
themselves (exact: the scan's modal response uses them).  Also the scalar modal response (1/G_n at one θ, in Python
numbers) the brackets evaluate.  ``cable_loop`` returns None where the factors are not trusted: Q = z/(z − 1)/G_n
from the factors differs from the modal response by > 1e-9 at a few angles, or any factor lies within 1e3 of its own
error of the unit circle.

A resonance within MIN_MODE_GAP of the circle, or a zero of G within MIN_CIRCLE_GAP of it, is "near" (issue 32:
they were refused, and were 3.5 % of random damped cables' fallbacks to the bounded scan): beside it the modal
response (the scan's function, whose values F and R the brackets read) is known only to ≈ ferr/|e^{jθ} − c|
relative (ferr = 8ε|w| + 2·err: the rounding of e^{jθ} − 1 and of λ, ≈ ε|w| each, in e^{jθ} − 1 − λ, 2× padded; for
a zero, its root's error), which the brackets allow for (optim.stability.cable_brackets: a level or β within that
of a value they read, or an answer whose crossover is worse conditioned than MAX_NEAR_ERROR, send the device to the
bounded scan).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.polynomial import polynomial as P

__all__ = ["CableLoop", "cable_loop", "loop_arrays", "MIN_CIRCLE_GAP", "MIN_MODE_GAP", "MAX_NEAR_ERROR", "Factor", "expm1j", "inverse_response_at",
           "root_errors"]

_EPS = 2.220446049250313e-16
_TWO_PI = 2.0 * math.pi
#: zeros of G closer than this to the unit circle (| |ζ| − 1 |) are near (module docstring; they were refused)
MIN_CIRCLE_GAP = 1e-9
#: resonances (poles of G) closer than this to the unit circle are near (until issue 32 every such device was the
#: bounded scan's).  The brackets gave B_max 7.8e-7 too high on a
#: cable whose resonance pole sat 2.4e-11 from the circle, its damper crossover 4.2e-10 from it (δ = 1e-9; design
#: property run of 2026-12-01, seed 17 case 2741; the 40-digit reference and the closed loop agree on the lower one)
MIN_MODE_GAP = 1e-8
#: the most relative error of the modal response (Σ ferr/|e^{jθ} − c| over the near factors) an answer's crossover may
#: have: what a crossover MIN_MODE_GAP from a resonance at |w| = 2 had when MIN_MODE_GAP refused the nearer ones
#: (16ε·2/1e-8 = 7.1e-7).  Case 2741 above: 8ε·0.57/4.2e-10 = 2.4e-6, the bounded scan's
MAX_NEAR_ERROR = 16.0 * _EPS * 2.0 / MIN_MODE_GAP


def _mode_gap_floor(f: Factor) -> float:
    """The least distance to the unit circle a pole of G may have for the brackets: MIN_MODE_GAP for a resonance;
    for the real slow pole 1 − δ' (δ' ≈ δ, the device's absolute damping) only its own error (and > 0): it sits at
    θ = 0, below every piece (θ ≥ θ_min), where |e^{jθ} − c| ≥ θ·cos(θ/2) ≫ its error.  With the blanket 1e-8 rule
    every cable with δ < 1e-8 took the bounded scan (210 of bench_core's 235 fallbacks in 1,000 random cables,
    issue 32); tests/optim/stability/test_cable_slow_pole.py holds them to the scan."""
    return MIN_MODE_GAP if f.w.imag != 0.0 else 0.0


def _near(f: Factor) -> Factor:
    """``f`` marked near the circle (module docstring) when it is: a resonance within MIN_MODE_GAP, a zero of G within
    MIN_CIRCLE_GAP (the real slow pole sits at θ = 0, below every piece: _mode_gap_floor)."""
    floor = MIN_CIRCLE_GAP if f.sign < 0 else _mode_gap_floor(f)
    if not f.gap < floor:
        return f
    return replace(f, ferr=8.0 * _EPS * abs(f.w) + 2.0 * f.err)


def _angles_in(base: float) -> float | None:
    """The angle base + 2πk in [0, π], if any."""
    for k in (-1, 0, 1):
        x = base + _TWO_PI * k
        if 0.0 <= x <= math.pi:
            return x
    return None


@dataclass(frozen=True)
class Factor:
    """A factor (z − c)^sign of Q, with what the bounds need of it."""

    w: complex        # c − 1 (accurate: from λ or a root in w)
    c: complex        # c = 1 + w
    sign: int         # +1: a factor of Q's numerator (c_k), −1: of its denominator (ζ_i)
    mag: float        # |c|
    om2: float        # (1 − |c|²)/2, without cancellation
    gap: float        # | |c| − 1 |: the least |e^{jθ} − c|, less err
    err: float        # how far c may be from the exact factor of the scan's function (a root's error)
    inside: bool
    base: float       # arg(−c) for a factor outside the unit circle (the continuous branch's constant)
    inv_neg_c: complex  # 1/(−c)
    om_lo: float      # om2 ∓ its error (the root's error moves |c|)
    om_hi: float
    t_near: float | None   # the angle in [0, π] nearest to c (arg c), if any
    t_far: float | None    # the farthest (arg c + π)
    t_smax: float | None   # where |c| sin(θ − arg c) is largest (arg c + π/2)
    t_smin: float | None   # and least (arg c − π/2)
    ferr: float = 0.0      # near the circle (module docstring): the modal response's relative error ≲ ferr/|e^{jθ} − c|


@dataclass(frozen=True)
class CableLoop:
    """The factored loop of the module docstring (dimensionless)."""

    factors: tuple[Factor, ...]   # Q's numerator's c_k (sign +1), then its denominator's ζ_i (sign −1)
    s: int
    lead_arg: float                # arg L
    lead_abs: float                # |L|
    modal: tuple
    d: int
    splits: tuple[float, ...]      # angles of the poles and zeros in (0, π)
    # per factor of Q's numerator (num) and denominator (den), in plain Python numbers for the brackets' hot
    # loop: (w, inside, base, inv_neg_c, om2, Re c, Im c)
    num: tuple = ()
    den: tuple = ()
    num_w: tuple = ()              # the w of num and of den alone
    den_w: tuple = ()
    # the loop as the compiled brackets read it (optim.stability.cable_kernel; loop_arrays)
    arrays: tuple = field(default=(), compare=False, repr=False)


def _factor(w: complex, sign: int, err: float) -> Factor:
    c = 1.0 + w
    om2 = -(w.real + 0.5 * abs(w) ** 2)
    mag = abs(c)
    psi = cmath.phase(c)
    inside = mag < 1.0
    err += 4.0 * _EPS * abs(w)
    return Factor(w, c, sign, mag, om2, abs(2.0 * om2) / (1.0 + mag) - err, err, inside,
                   0.0 if inside else cmath.phase(-c), 0j if inside else -1.0 / c, om2 - err * (1.0 + mag), om2 + err * (1.0 + mag),
                   _angles_in(psi), _angles_in(psi + math.pi), _angles_in(psi + 0.5 * math.pi),
                   _angles_in(psi - 0.5 * math.pi))


def _pmul(a: list, b: list) -> list:
    """The product of two polynomials (ascending coefficients, Python numbers)."""
    out = [0j] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] += x * y
    return out


def _numerator_w(modal, fractional: bool) -> np.ndarray:
    """Coefficients (ascending, in w) of z^m·G_n·z^d·w·Π(w − λ): the modal form's numerator (real: its imaginary
    parts, rounding, dropped).  In Python numbers (numpy's polynomial helpers cost ~50 µs a product on these
    degree-≤ 5 polynomials: most of a new device's factoring, issue 32)."""
    lam, c1, c2v, e12v, r0, r1, g0_1, g1_1 = modal
    lam = [complex(v) for v in lam]
    c1, g0_1, g1_1 = complex(c1), complex(g0_1), complex(g1_1)
    prod = [1.0 + 0j]
    for lk in lam:
        prod = _pmul(prod, [-lk, 1.0 + 0j])
    if fractional:
        out = _pmul([c1 * (g0_1 + g1_1), c1 * g0_1], prod)       # c1·(g0₁·(1 + w) + g1₁)
    else:
        out = [c1 * g0_1 * v for v in prod]
    for i in range(len(lam)):
        rest = [1.0 + 0j]
        for k, lk in enumerate(lam):
            if k != i:
                rest = _pmul(rest, [-lk, 1.0 + 0j])
        ri0, ri1 = complex(r0[i]), complex(r1[i])
        inp = [ri0 + ri1, ri0] if fractional else [ri0]
        term = _pmul(_pmul(inp, [c1 * complex(e12v[i]), complex(c2v[i])]), rest)
        out = [x + y for x, y in zip(out, term)] + out[len(term):] if len(out) >= len(term) else \
            [x + y for x, y in zip(out, term)] + term[len(out):]
    return np.array([v.real for v in out])


def root_errors(coef: list[float], roots: list[complex]) -> list[float]:
    """64ε·Σ|a_k||w|^k/|p'(w)| of each root w of p (ascending real coefficients ``coef``), in Python numbers: the
    bits of numpy.polynomial's ``64ε·polyval(|w|, |coef|)/max(|polyval(w, polyder(coef))|, 1e-300)`` (the same Horner
    steps, each rounded alike: tests/optim/stability/test_cable_loop_errs.py), without its array set-up per call
    (≈ 60 µs of a new cable's factoring, issue 32)."""
    n = len(coef)
    mags = [abs(a) for a in coef]
    der = [coef[k] * k for k in range(1, n)]          # polyder: a_k·k
    out = []
    for w in roots:
        x = abs(w)
        num = mags[-1] + x * 0
        for k in range(n - 2, -1, -1):
            num = mags[k] + num * x
        dp = der[-1] + w * 0
        for k in range(n - 3, -1, -1):
            dp = der[k] + dp * w
        out.append(float(64.0 * _EPS * num / max(abs(dp), 1e-300)))
    return out


def cable_loop(plant) -> CableLoop | None:
    """The factored form of a cable ``plant`` (models.discretize.StateSpaceZOH), cached on it; None when untrusted."""
    cache = plant._cache
    if "cable_loop" not in cache:
        cache["cable_loop"] = _build(plant)
    return cache["cable_loop"]


#: why the last ``_build`` returned None (a debug label for bench/bench_cable_fallbacks.py; never in an answer)
last_reason: list[str] = [""]


def _build(plant) -> CableLoop | None:
    modal = plant.modal_form()
    if modal is None or len(modal[0]) != 3:
        last_reason[0] = "no modal form"
        return None
    lam = modal[0]
    m = 1 if plant.f > 0.0 else 0
    coef = _numerator_w(modal, m == 1)
    while coef.size > 1 and coef[-1] == 0.0:
        coef = coef[:-1]
    if coef.size < 2 or not np.all(np.isfinite(coef)):
        last_reason[0] = "numerator degenerate"
        return None
    wz = P.polyroots(coef)
    # the modes λ are the scan's own (its modal response uses them): exact here; the roots in w are computed, and
    # each is off by ≲ ε·Σ|a_k||w|^k/|p'(w)| (padded 64×), which every distance bound allows for
    errs = root_errors(coef.tolist(), [complex(v) for v in wz])
    factors = tuple(_factor(complex(v), 1, 0.0) for v in lam) + \
        tuple(_factor(complex(v), -1, e) for v, e in zip(wz, errs))
    # a factor within 1e3 of its own error of the unit circle: H (nearly) infinite or zero there, not resolved by
    # its factors; scan instead.  Nearer than the old gaps (MIN_CIRCLE_GAP, MIN_MODE_GAP) is "near" (module docstring)
    for f in factors:
        if f.gap < 1e3 * f.err or not f.gap > 0.0:
            kind = "zero" if f.sign < 0 else "resonance pole" if f.w.imag != 0.0 else "real pole"
            last_reason[0] = (f"{kind} near circle (gap {f.gap:.1e}, err {f.err:.1e}, "
                              f"{'near -1' if f.c.real < 0 and abs(f.c.imag) < 1e-3 else ''})")
            return None
    factors = tuple(_near(f) for f in factors)
    lead = float(coef[-1])
    hot = [(f.w, f.inside, f.base, f.inv_neg_c, f.om2, f.c.real, f.c.imag) for f in factors]
    loop = CableLoop(factors, plant.d + m + 1, 0.0 if lead > 0 else math.pi, abs(lead), _py_modal(modal), plant.d,
                     tuple(sorted({f.t_near for f in factors if f.t_near is not None and 0.0 < f.t_near < math.pi})),
                     tuple(h for h, f in zip(hot, factors) if f.sign > 0),
                     tuple(h for h, f in zip(hot, factors) if f.sign < 0),
                     tuple(f.w for f in factors if f.sign > 0), tuple(f.w for f in factors if f.sign < 0))
    return _checked(loop)


def _checked(loop: CableLoop) -> CableLoop | None:
    """``loop`` with its arrays when its factored Q agrees with the modal response (the scan's own evaluation) at a
    few angles, at its d whole samples of delay; else None (last_reason says why)."""
    for t in (1e-3, 0.1, 0.7, 1.3, 2.1, 2.9, 3.1):
        q = _q(loop, t)
        ref = inverse_response_at(loop.modal, loop.d, t) / (-expm1j(-t))
        if not abs(q / ref - 1.0) < 1e-9:
            last_reason[0] = f"factor mismatch {abs(q / ref - 1.0):.1e} at {t}"
            return None
    return replace(loop, arrays=loop_arrays(loop))


def with_whole_delay(loop: CableLoop, d: int) -> CableLoop | None:
    """What cable_loop gives for the same sampled plant with d whole samples of delay instead of ``loop.d`` (issue 32):
    the modal form, the factors and the splits depend on the fractional delay alone, so only s = d + m + 1 and d
    change, and the check against the modal response is made again at d (None where it fails, as there)."""
    return _checked(replace(loop, s=loop.s - loop.d + d, d=d, arrays=()))


def _nan(x: float | None) -> float:
    return math.nan if x is None else x


def loop_arrays(loop: CableLoop) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(reals, complex, modal, numbers, splits) of ``loop``, as optim.stability.cable_kernel reads them: per factor
    (Q's numerator's c_k, then its denominator's ζ_i) a row of reals (sign, |c|, gap, err, inside, arg(−c), the two
    bounds of (1 − |c|²)/2, the four angles t_near, t_far, t_smax, t_smin, NaN where None, ferr) and a row of complex (w,
    c, 1/(−c)); the modal form's 3 modes (λ, r0, r1, e12, c2) then c1, g0₁, g1₁; the numbers s, arg L, |L|, d, and
    1 where a factor is near the unit circle (else 0); and
    the split angles."""
    fr = np.array([[float(f.sign), f.mag, f.gap, f.err, 1.0 if f.inside else 0.0, f.base, f.om_lo, f.om_hi,
                    _nan(f.t_near), _nan(f.t_far), _nan(f.t_smax), _nan(f.t_smin), f.ferr]
                   for f in loop.factors])
    fc = np.array([[f.w, f.c, f.inv_neg_c] for f in loop.factors], dtype=complex)
    modes, c1, g0_1, g1_1 = loop.modal
    modal = np.array([v for mode in modes for v in mode] + [c1, g0_1, g1_1], dtype=complex)
    nums = np.array([float(loop.s), loop.lead_arg, loop.lead_abs, float(loop.d),
                     1.0 if any(f.ferr > 0.0 for f in loop.factors) else 0.0])
    return fr, fc, modal, nums, np.array(loop.splits, dtype=float)


def expm1j(t: float) -> complex:
    """e^{jt} − 1 without cancellation."""
    sh = math.sin(0.5 * t)
    return complex(-2.0 * sh * sh, math.sin(t))


def _py_modal(modal) -> tuple:
    """The modal form as Python numbers (numpy scalars are ~5× slower in scalar arithmetic)."""
    lam, c1, c2v, e12v, r0, r1, g0_1, g1_1 = modal
    modes = tuple((complex(lam[i]), complex(r0[i]), complex(r1[i]), complex(e12v[i]), complex(c2v[i]))
                  for i in range(len(lam)))
    return modes, complex(c1), complex(g0_1), complex(g1_1)


def inverse_response_at(modal, d: int, t: float) -> complex:
    """1/G_n(e^{jθ}) by the modal form (_py_modal), as StateSpaceZOH.response computes it (scalar)."""
    modes, c1, g0_1, g1_1 = modal
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    zm1 = complex(-2.0 * sh * sh, st)
    zinv = complex(math.cos(t), -st)
    acc_e = 0j
    acc_c = 0j
    for lam, r0, r1, e12, c2 in modes:
        y = (r0 + zinv * r1) / (zm1 - lam)
        acc_e += y * e12
        acc_c += y * c2
    x1 = (g0_1 + zinv * g1_1 + acc_e) / zm1
    dt = d * t
    g = (c1 * x1 + acc_c) * complex(math.cos(dt), -math.sin(dt))
    return 1.0 / g


def _q(loop: CableLoop, t: float) -> complex:
    zm1 = expm1j(t)
    out = cmath.exp(1j * loop.s * t) / (loop.lead_abs * cmath.exp(1j * loop.lead_arg))
    for f in loop.factors:
        out = out * (zm1 - f.w) if f.sign > 0 else out / (zm1 - f.w)
    return out
