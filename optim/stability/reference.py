"""Extended-precision reference for K_cr(B) (the ``reference`` rung; slow by design).

An independent implementation of the same definition: the plant is discretised
in mpmath (matrix exponential of the augmented matrix in the *physical*
coordinates [x_r, x_d, v_r, v_d], or the rigid closed form with mpmath's exp),
the loop function H(θ) = -1/G(e^{jθ}) - β(1 - e^{-jθ}) is scanned on a grid of its
own and every sign change of Im H with Re H > 0 is bisected to ``dps`` digits.
It shares no numerical code with the double-precision ``exact`` path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mpmath as mp

from models.device import Device
from models.discretize import split_delay
from optim.errors import InputError
from optim.stability.undamped_cable import is_undamped_cable
from optim.stability.undamped_cable import refuse as refuse_undamped

__all__ = ["cable_h", "ReferenceResult", "reference_critical_stiffness", "REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES"]

#: Cap of the 40-digit K_cr rung itself (any caller): its scan grows with the delay in samples (docs/limits.md).
REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES = 2000


@dataclass(frozen=True)
class ReferenceResult:
    critical_stiffness: float
    crossover_frequency: float | None
    crossovers: tuple[tuple[float, float], ...]
    """(ω [rad/s], K [N/m]) of every crossover with K > 0."""
    digits: int
    reason: str | None = None
    """Why K_cr is 0 or ∞ when the scan did not find it (None otherwise)."""


def _rigid_h(delta, d: int, f, beta):
    one = mp.mpf(1)
    a = delta

    def g0(z):
        # a = 0 (no physical damping): 1/s², step response y(τ) = τ²/2; Σ (k + m)²/2 z^{-k} from Σ z^{-k},
        # Σ k z^{-k} = z/(z − 1)² and Σ k² z^{-k} = z(z + 1)/(z − 1)³ (m = 0 without a fractional delay).
        m_ = one - f if f > 0 else mp.mpf(0)
        zm1 = z - 1
        zs = z / zm1 * m_**2 / 2 + z / zm1**2 * m_ + z * (z + 1) / zm1**3 / 2
        return (1 - 1 / z) * z ** (-d - (1 if f > 0 else 0)) * zs

    def g(z):
        # Modified z-transform of 1/(s²(s+a)) (dimensionless, m = T = 1), ZOH and delay d + f.
        if a == 0:
            return g0(z)
        m_ = one - f                                         # modified-z parameter
        e = mp.exp(-a)
        em = mp.exp(-a * m_)
        # step response y(τ) = τ/a - (1 - e^{-aτ})/a²; Z_m of the step response sampled at k + m:
        zm1 = z - 1
        zs = z / zm1 * (m_ / a - 1 / a**2) + z / zm1**2 / a + em / a**2 * z / (z - e)
        # G(z) = (1 - z^-1) z^{-d-1} Z_m[...]  when f > 0, (1 - z^-1) z^{-d} Z[...] when f = 0
        if f == 0:
            zs0 = z / zm1 * (-1 / a**2) + z / zm1**2 / a + z / (z - e) / a**2
            return (1 - 1 / z) * z ** (-d) * zs0
        return (1 - 1 / z) * z ** (-d - 1) * zs

    def h(theta):
        z = mp.expj(theta)
        return -1 / g(z) - beta * (1 - 1 / z)
    return h


def _cable_h(device: Device, d: int, f, beta):
    c, m, t = device.cable, mp.mpf(device.mass), mp.mpf(device.sample_time)
    mr, md = mp.mpf(c.motor_mass) / m, mp.mpf(c.body_mass) / m
    br, bd = mp.mpf(c.motor_damping) * t / m, mp.mpf(c.body_damping) * t / m
    k, bc = mp.mpf(c.stiffness) * t * t / m, mp.mpf(c.damping) * t / m
    a = mp.matrix([[0, 0, 1, 0], [0, 0, 0, 1],
                   [-k / mr, k / mr, -(br + bc) / mr, bc / mr],
                   [k / md, -k / md, bc / md, -(bd + bc) / md]])
    b = mp.matrix([0, 0, 1 / mr, 0])

    def aug(sigma):
        big = mp.zeros(5, 5)
        for i in range(4):
            for j in range(4):
                big[i, j] = a[i, j] * sigma
            big[i, 4] = b[i] * sigma
        e = mp.expm(big)
        return e[0:4, 0:4], e[0:4, 4]

    phi, _ = aug(mp.mpf(1))
    e0, g0 = aug(1 - f)
    if f > 0:
        _, pf = aug(f)
        g1 = e0 * pf
    else:
        g1 = mp.zeros(4, 1)
    eye = mp.eye(4)

    def h(theta):
        z = mp.expj(theta)
        x = mp.lu_solve(z * eye - phi, g0 + g1 / z)
        g = x[0] * z ** (-d)
        return -1 / g - beta * (1 - 1 / z)
    return h


#: H(θ) of a cable in the working precision (optim.stability.near_b_max re-solves a crossover with it)
cable_h = _cable_h


def _bisect(h, lo, hi, digits: int):
    flo = mp.im(h(lo))
    tol = mp.mpf(10) ** (-digits + 5) * hi
    while hi - lo > tol:
        mid = (lo + hi) / 2
        fm = mp.im(h(mid))
        if fm == 0:
            return mid
        if mp.sign(fm) == mp.sign(flo):
            lo, flo = mid, fm
        else:
            hi = mid
    return (lo + hi) / 2


#: the largest turn of arg H between neighbouring samples after refinement [rad], and the bisection rounds allowed
_MAX_TURN = 0.5
_REFINE_ROUNDS = 40


def _refine(h, pts: list[float], vals: list) -> tuple[list[float], list]:
    """Bisect every interval where arg H turns by more than :data:`_MAX_TURN`: two crossings between samples
    (H passing close to the origin, as near B_max where K_cr → 0) turn arg H by ~π and are then bracketed apart.
    A fixed grid missed one 1.1e-3 rad wide (crossovers at θ = 0.1317 and 0.1328 on a 2.2e-3 rad grid: K_cr
    78.34 against the true 2.398, tests/optim/stability/test_reference.py)."""
    for _ in range(_REFINE_ROUNDS):
        new_pts, new_vals, split = [pts[0]], [vals[0]], False
        for p0, v0, p1, v1 in zip(pts, vals, pts[1:], vals[1:]):
            if p1 - p0 > 1e-13 * p1 and (v0 == 0 or v1 == 0 or abs(mp.arg(v1 / v0)) > _MAX_TURN):
                mid = 0.5 * (p0 + p1)
                new_pts.append(mid)
                new_vals.append(h(mp.mpf(mid)))
                split = True
            new_pts.append(p1)
            new_vals.append(v1)
        pts, vals = new_pts, new_vals
        if not split:
            break
    return pts, vals


def _scan(h, device: Device, beta: float, digits: int) -> list[tuple[float, float]]:
    """Every θ in (0, π] with h(θ) real and positive, bisected to ``digits`` digits."""
    damp = device.delta + beta
    dd = device.delay_samples
    # The first crossover of a lightly damped loop sits near sqrt(damping/(1 + 2d)); without any damping (only
    # the damper-only loop of a frictionless device is scanned so) nothing crosses at low θ, where H → 0 along
    # the imaginary axis.
    lo = 1e-4 * min(1.0, math.sqrt(damp / (1 + 2 * dd)), 10 * damp) if damp > 0 else 1e-4 / math.sqrt(1 + 2 * dd)
    pts = [lo * (0.05 / lo) ** (i / 300) for i in range(301)] if lo < 0.05 else []
    step = min(0.01, math.pi / (12 * (dd + 1)))
    n = int(math.ceil((math.pi - 0.05) / step))
    pts += [0.05 + (math.pi - 0.05) * i / n for i in range(1, n + 1)]
    if device.cable is not None:
        w = device.cable.natural_frequency * device.sample_time
        wz = math.sqrt(device.cable.stiffness / device.cable.body_mass) * device.sample_time
        for centre in (w, wz):
            centre = math.fmod(centre, 2 * math.pi)
            centre = 2 * math.pi - centre if centre > math.pi else centre
            pts += [centre * (1 + s * 10 ** (-e / 4)) for e in range(0, 40) for s in (-1, 1)]
    pts = sorted(p for p in set(pts) if lo <= p <= math.pi)
    pts, vals = _refine(h, pts, [h(mp.mpf(p)) for p in pts])
    found: list[tuple[float, float]] = []
    for (p0, v0), (p1, v1) in zip(zip(pts, vals), zip(pts[1:], vals[1:])):
        if mp.sign(mp.im(v0)) * mp.sign(mp.im(v1)) < 0 and (mp.re(v0) > 0 or mp.re(v1) > 0):
            root = _bisect(h, mp.mpf(p0), mp.mpf(p1), digits)
            val = mp.re(h(root))
            if val > 0 and math.pi - float(root) > 1e-9:
                found.append((float(root), float(val)))
    v_pi = mp.re(h(mp.pi))
    if v_pi > 0:
        found.append((math.pi, float(v_pi)))
    return found


def reference_critical_stiffness(device: Device, damping: float = 0.0, digits: int = 40) -> ReferenceResult:
    """K_cr(B) in ``digits``-digit arithmetic (B below B_max is assumed; see optim.stability.margins).

    Without any damping (δ = β = 0) the rigid mode is a double pole at z = 1 that every K > 0 with the hold's lag
    drives out: K_cr = 0 in closed form, as the exact rung's linear condition says.  A cable with every damping 0
    and B > 0 has its mode on the unit circle, where this scan cannot tell it from a crossing: refused (the exact
    rung decides it by the root locus and the closed loop, optim.stability.undamped_cable).
    """
    if device.delay_samples > REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES:
        raise InputError("delay", f"the reference rung is capped at {REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES} samples of delay")
    if device.delta == 0.0 and damping == 0.0:
        return ReferenceResult(0.0, None, (), digits, "no physical or virtual damping (δ = β = 0): the double pole "
                               "at z = 1 leaves the unit circle at any K > 0, so no positive stiffness is stable")
    if is_undamped_cable(device):
        raise refuse_undamped("the reference rung's scan cannot tell the cable mode on the unit circle from a "
                              "crossing (method 'exact' decides it by the root locus and the closed loop)")
    # The rigid closed form cancels like 1/δ² (partial fractions): carry extra digits for it (δ = 0 has its own).
    extra = 10 + 2 * max(0, int(-math.log10(device.delta))) if device.delta > 0 else 10
    with mp.workdps(digits + extra):
        d_int, f = split_delay(device.delay_samples)
        f = mp.mpf(f)
        beta = mp.mpf(damping) * mp.mpf(device.sample_time) / mp.mpf(device.mass)
        if device.cable is None:
            h = _rigid_h(mp.mpf(device.damping) * mp.mpf(device.sample_time) / mp.mpf(device.mass), d_int, f, beta)
        else:
            h = _cable_h(device, d_int, f, beta)
        found = _scan(h, device, float(beta), digits)
        if beta > 0:
            # the damper-only loop must be stable at K = 0+ (optim.stability.margins): B < B_max
            hb = (lambda th: (h(th) + beta * (1 - 1 / mp.expj(th))) / (1 - 1 / mp.expj(th)))
            b_cross = _scan(hb, device, 0.0, digits)
            if b_cross and float(beta) >= min(v for _, v in b_cross):
                return ReferenceResult(0.0, None, (), digits, "virtual damping at or above the largest stable "
                                       "virtual damping: no positive stiffness is stable")
    scale, t = device.stiffness_scale, device.sample_time
    cross = tuple((th / t, v * scale) for th, v in found)
    if not cross:
        return ReferenceResult(math.inf, None, (), digits)
    w, k = min(cross, key=lambda c: c[1])
    return ReferenceResult(k, w, cross, digits)
