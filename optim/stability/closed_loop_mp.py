"""The sampled plant of optim.stability.closed_loop in mpmath: the same continuous model, the same coordinates.

``verify`` decides a closed-loop pole that double precision cannot place (optim/verification.py) with this twin of
optim.stability.closed_loop.sampled_plant: the device's continuous state space written out in mpmath from its
physical parameters (time in samples, masses in units of m), discretised by mpmath's matrix exponential of the
augmented matrix, the fractional delay in two input matrices.  The inputs are the device's doubles, taken as exact.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import mpmath as mp

from models.device import Device
from optim.stability.closed_loop import split_delay_samples

__all__ = ["MpPlant", "MpSampled", "PRECISE_DIGITS", "mp_plant", "mp_plant_response", "mp_return_difference",
           "mp_sampled", "mp_sampled_response"]

#: digits of verify's mpmath decisions (the issue's audit tracked roots in 50)
PRECISE_DIGITS = 50


@dataclass(frozen=True)
class MpPlant:
    """x[k+1] = x[k] + E x[k] + Γ0 u[k−d] + Γ1 u[k−d−1], y = x[0], in mpmath numbers (see closed_loop.SampledPlant)."""

    e: mp.matrix
    g0: mp.matrix
    g1: mp.matrix
    d: int
    f: mp.mpf
    digits: int


def _continuous(device: Device) -> tuple[mp.matrix, mp.matrix]:
    m, t = mp.mpf(device.mass), mp.mpf(device.sample_time)
    cb = device.cable
    if cb is None:
        delta = mp.mpf(device.damping) * t / m
        return mp.matrix([[0, 1], [0, -delta]]), mp.matrix([0, 1])
    mr, md = mp.mpf(cb.motor_mass) / m, mp.mpf(cb.body_mass) / m
    br, bd, bc = (mp.mpf(cb.motor_damping) * t / m, mp.mpf(cb.body_damping) * t / m, mp.mpf(cb.damping) * t / m)
    kc = mp.mpf(cb.stiffness) * t * t / m
    a = mp.matrix([[0, 1, 0, -md],
                   [0, -(br + bd), 0, -(bd * mr - br * md)],
                   [0, 0, 0, 1],
                   [0, br / mr - bd / md, -kc / md - kc / mr, -(bd * mr) / md - bc / md - bc / mr - br * md / mr]])
    return a, mp.matrix([0, 1, 0, -1 / mr])


def _psi(a: mp.matrix, sigma) -> tuple[mp.matrix, mp.matrix]:
    """(e^{Aσ}, Ψ(σ) = ∫₀^σ e^{As} ds) in the working precision: the series Ψ(τ) = τ·Σ (Aτ)^k/(k + 1)! at
    τ = σ/2^s (‖Aτ‖₁ ≤ 1/2), then s doublings Ψ(2τ) = (I + e^{Aτ})·Ψ(τ), e^{2Aτ} = (e^{Aτ})² (4×4 products: an
    eighth of the augmented exponential's cost)."""
    n = a.rows
    eye = mp.eye(n)
    norm = mp.mnorm(a, 1) * abs(sigma)
    s = max(0, int(mp.ceil(mp.log(norm, 2))) + 1) if norm > 0 else 0
    tau = mp.mpf(sigma) / 2 ** s
    y = a * tau
    term, total, k = eye, eye, 1
    tol = mp.mpf(10) ** (-mp.mp.dps)
    while mp.mnorm(term, 1) > tol:
        k += 1
        term = term * y / k
        total += term
    psi = total * tau
    phi = eye + a * psi
    for _ in range(s):
        psi = (eye + phi) * psi
        phi = phi * phi
    return phi, psi


@lru_cache(maxsize=32)
def mp_plant(device: Device, digits: int = PRECISE_DIGITS) -> MpPlant:
    """The plant sampled in ``digits`` digits (its numbers carry digits + 10 while built; kept per device: a verify
    checks one device at two or three gains)."""
    with mp.workdps(digits + 10):
        a, b = _continuous(device)
        e, g0, g1, d, f = _sample(a, b, device.delay, device.sample_time)
        for i in range(a.rows):
            e[i, 0] = mp.mpf(0)           # nothing depends on the motor position (A's first column is zero)
        return MpPlant(e, g0, g1, d, f, digits)


def _sample(a: mp.matrix, b: mp.matrix, delay: float, sample_time: float) -> tuple:
    """(E, Γ0, Γ1, d, f): the continuous (A, B) (time in samples) sampled with a zero-order hold and the delay's d
    whole samples and fraction f in the working precision; f is the fraction of the exact quotient of the inputs
    (the double quotient rounds it)."""
    d, frac = split_delay_samples(delay / sample_time)
    f = mp.mpf(delay) / mp.mpf(sample_time) - d if frac > 0.0 else mp.mpf(0)
    _, psi1 = _psi(a, mp.mpf(1))
    e = a * psi1
    if f == 0:
        return e, psi1 * b, mp.zeros(a.rows, 1), d, f
    ex_late, psi_late = _psi(a, 1 - f)
    _, psi_early = _psi(a, f)
    return e, psi_late * b, ex_late * psi_early * b, d, f


def mp_plant_response(plant: MpPlant, theta) -> mp.mpc:
    """G(e^{jθ}) = z^{−d}·c((z − 1)I − E)⁻¹(Γ0 + Γ1 z⁻¹), c = e₀ᵀ, in the plant's digits (θ an mpf or a float)."""
    with mp.workdps(plant.digits + 10):
        th = mp.mpf(theta)
        x = _resolvent_solve(plant.e, plant.g0, plant.g1, th)
        return x[0] * mp.expj(-plant.d * th)


def _resolvent_solve(e: mp.matrix, g0: mp.matrix, g1: mp.matrix, th) -> mp.matrix:
    """x = ((z − 1)I − E)⁻¹(Γ0 + Γ1 z⁻¹) at z = e^{jθ}, z − 1 written as −2 sin²(θ/2) + j sin θ (no cancellation
    near θ = 0), in the caller's working precision."""
    n = e.rows
    zm1 = -2 * mp.sin(th / 2) ** 2 + 1j * mp.sin(th)
    zinv = mp.expj(-th)
    mat = mp.matrix(n, n)
    for i in range(n):
        for j in range(n):
            mat[i, j] = -e[i, j]
        mat[i, i] += zm1
    return mp.lu_solve(mat, g0 + g1 * zinv)


def mp_return_difference(device: Device, alpha: float, beta: float, digits: int = PRECISE_DIGITS,
                         controller: tuple[tuple[float, ...], tuple[float, ...]] | None = None) -> Callable:
    """θ ↦ F(e^{jθ}) = 1 + C(z)·G(z) in mpmath (θ an mpf), the plant sampled in ``digits`` digits.

    C = α + β(1 − z⁻¹) (the wall); ``controller`` = (P, D): C = P(w)/D(w) in ascending powers of w = z⁻¹ instead
    (a rendered wall's difference equation, optim.stability.closed_loop_rendered); the doubles are taken as exact."""
    with mp.workdps(digits + 10):
        a, b = mp.mpf(alpha), mp.mpf(beta)
        num = [mp.mpf(c) for c in controller[0]] if controller else []
        den = [mp.mpf(c) for c in controller[1]] if controller else []

    def poly(coeffs, w):
        out = mp.mpf(0)
        for c in reversed(coeffs):
            out = out * w + c
        return out

    def f(theta):
        with mp.workdps(digits + 10):
            w = mp.expj(-theta)
            ctrl = poly(num, w) / poly(den, w) if controller else a + b * (1 - w)
            return 1 + ctrl * mp_plant_response(mp_plant(device, digits), theta)   # built at the first call
    return f


@dataclass(frozen=True)
class MpSampled:
    """Any continuous (A, B, C, D) sampled in mpmath (see closed_loop.discretise): x[k+1] = x[k] + E x[k] +
    Γ0 u[k−d] + Γ1 u[k−d−1], y = c·x + direct·u[k−d−1] (a direct term acts through the sample before the hold)."""

    e: mp.matrix
    g0: mp.matrix
    g1: mp.matrix
    c: mp.matrix
    direct: mp.mpf
    d: int
    f: mp.mpf
    digits: int


def mp_sampled(a, b, c, direct: float, delay: float, sample_time: float, digits: int = PRECISE_DIGITS) -> MpSampled:
    """The twin of closed_loop.discretise in ``digits`` digits for a continuous state space given in doubles (time
    in samples), taken as exact: the feedforward loop's plant (models.feedforward.feedforward_state_space), whose
    entries are the device's and the grasp's parameters in one or two double operations.  The delay's fraction is
    the exact quotient of ``delay`` and ``sample_time`` [s] (as in :func:`mp_plant`)."""
    with mp.workdps(digits + 10):
        n = len(b)
        am = mp.matrix(n, n)
        for i in range(n):
            for j in range(n):
                am[i, j] = mp.mpf(float(a[i][j]))
        bm = mp.matrix([mp.mpf(float(x)) for x in b]) if n else mp.matrix(0, 1)
        cm = mp.matrix([[mp.mpf(float(x)) for x in c]]) if n else mp.matrix(1, 0)
        e, g0, g1, d, f = _sample(am, bm, delay, sample_time)
        return MpSampled(e, g0, g1, cm, mp.mpf(direct), d, f, digits)


def mp_sampled_response(plant: MpSampled, theta) -> mp.mpc:
    """G(e^{jθ}) = z^{−d}·c((z − 1)I − E)⁻¹(Γ0 + Γ1 z⁻¹) + direct·z^{−d−1} in the plant's digits."""
    with mp.workdps(plant.digits + 10):
        th = mp.mpf(theta)
        n = plant.e.rows
        x = _resolvent_solve(plant.e, plant.g0, plant.g1, th)
        g = mp.mpf(0)
        for i in range(n):
            g += plant.c[0, i] * x[i]
        return g * mp.expj(-plant.d * th) + plant.direct * mp.expj(-(plant.d + 1) * th)
