"""A second, independent way to K_cr: eigenvalues of the closed-loop state matrix.

Shares no code with models.discretize / optim.stability.margins: the plant is discretised
in *physical* coordinates (positions and velocities of each mass, not the
centre-of-mass form the core uses), the delay is a shift register of past
forces, and the stiffness that puts a closed-loop eigenvalue on the unit circle
is found by root-finding on its modulus.  mpmath variants carry 30+ digits.
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq


def physical_model(device) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dimensionless (time in samples, mass in units of m) A, B, C in physical coordinates."""
    m, t = device.mass, device.sample_time
    if device.cable is None:
        a = np.array([[0.0, 1.0], [0.0, -device.damping * t / m]])
        return a, np.array([0.0, 1.0]), np.array([1.0, 0.0])
    c = device.cable
    mr, md = c.motor_mass / m, c.body_mass / m
    br, bd, bc = c.motor_damping * t / m, c.body_damping * t / m, c.damping * t / m
    k = c.stiffness * t * t / m
    a = np.array([[0, 0, 1, 0], [0, 0, 0, 1],
                  [-k / mr, k / mr, -(br + bc) / mr, bc / mr],
                  [k / md, -k / md, bc / md, -(bd + bc) / md]], dtype=float)
    return a, np.array([0.0, 0.0, 1.0 / mr, 0.0]), np.array([1.0, 0.0, 0.0, 0.0])


def split(delay_samples: float) -> tuple[int, float]:
    d = int(math.floor(delay_samples + 1e-12))
    f = delay_samples - d
    return (d, 0.0) if abs(f) < 1e-12 else (d, f)


def discretise(a, b, delay_samples):
    """Φ, Γ0 (last 1-f of the period), Γ1 (first f), from 2n×2n exponentials of [[A, B], [0, 0]]."""
    d, f = split(delay_samples)
    n = a.shape[0]

    def ex(sigma):
        big = np.zeros((n + 1, n + 1))
        big[:n, :n], big[:n, n] = a, b
        e = expm(big * sigma)
        return e[:n, :n], e[:n, n]

    phi, _ = ex(1.0)
    e0, g0 = ex(1.0 - f)
    g1 = e0 @ ex(f)[1] if f > 0 else np.zeros(n)
    return phi, g0, g1, d


def closed_loop(phi, g0, g1, c, d, alpha, beta):
    """State [x; y_prev; u[k-1], ..., u[k-d-1]] of the loop u[k] = -(α y + β (y - y_prev))."""
    n = phi.shape[0]
    size = n + 1 + d + 1
    m = np.zeros((size, size), dtype=phi.dtype)
    # u[k] as a row over the state
    u = np.zeros(size, dtype=phi.dtype)
    u[:n] = -(alpha + beta) * c
    u[n] = beta
    buf = n + 1                      # buffer[j] = u[k-1-j], j = 0..d
    m[:n, :n] = phi
    if d == 0:
        m[:n, :] += np.outer(g0, u)
    else:
        m[:n, buf + d - 1] += g0
    m[:n, buf + d] += g1
    m[n, :n] = c
    m[buf, :] = u
    for j in range(1, d + 1):
        m[buf + j, buf + j - 1] = 1.0
    return m


def eigen_critical_alpha(device, beta, alpha_guess, theta_guess, rel=1e-3):
    """α where the eigenvalue nearest e^{jθ} reaches the unit circle (brentq on its modulus)."""
    a, b, c = physical_model(device)
    phi, g0, g1, d = discretise(a, b, device.delay_samples)
    target = np.exp(1j * theta_guess)

    def excess(alpha):
        lam = np.linalg.eigvals(closed_loop(phi, g0, g1, c, d, alpha, beta))
        near = lam[np.argmin(np.abs(lam - target))]
        return abs(near) - 1.0

    lo, hi = alpha_guess * (1 - rel), alpha_guess * (1 + rel)
    return brentq(excess, lo, hi, xtol=1e-300, rtol=1e-15)


def spectral_radius(device, alpha, beta) -> float:
    a, b, c = physical_model(device)
    phi, g0, g1, d = discretise(a, b, device.delay_samples)
    return float(np.max(np.abs(np.linalg.eigvals(closed_loop(phi, g0, g1, c, d, alpha, beta)))))


def eq12_roots_mp(delta, alpha, beta, d: int, digits: int = 40):
    """Roots of the chapter's characteristic polynomial eq. 12 (rigid, integer delay) in mpmath."""
    with mp.workdps(digits):
        dl, al, be = mp.mpf(delta), mp.mpf(alpha), mp.mpf(beta)
        eps = mp.exp(-dl)
        # δ²(z − ε)(z − 1)z^{d+1} − (1 − ε − δ)(α + β)z² + [(1 − ε − δε)(α + β) + (1 − ε − δ)β]z − (1 − ε − δε)β
        lead = [dl**2, -dl**2 * (1 + eps), dl**2 * eps] + [0] * (d + 1)   # degree d + 3
        poly = [mp.mpf(x) for x in lead]
        deg = len(poly) - 1
        poly[deg - 2] += -(1 - eps - dl) * (al + be)
        poly[deg - 1] += (1 - eps - dl * eps) * (al + be) + (1 - eps - dl) * be
        poly[deg] += -(1 - eps - dl * eps) * be
        return mp.polyroots(poly[::-1], maxsteps=400, extraprec=4 * digits, asc=True)


def radius_excess_mp(device, stiffness: float, damping: float, digits: int = 50):
    """max |z| − 1 over the closed-loop poles of the wall (K, B) on a cable or rigid device, in ``digits``-digit
    mpmath: physical coordinates, the ZOH (and a fractional delay) from mpmath matrix exponentials, the whole delay as
    a shift register, the eigenvalues by mp.eig.  For a few samples of delay (the matrix grows with it)."""
    with mp.workdps(digits):
        m, t = mp.mpf(device.mass), mp.mpf(device.sample_time)
        if device.cable is None:
            a = mp.matrix([[0, 1], [0, -mp.mpf(device.damping) * t / m]])
            b = mp.matrix([0, 1])
        else:
            c = device.cable
            mr, md = mp.mpf(c.motor_mass) / m, mp.mpf(c.body_mass) / m
            br, bd, bc = (mp.mpf(v) * t / m for v in (c.motor_damping, c.body_damping, c.damping))
            k = mp.mpf(c.stiffness) * t * t / m
            a = mp.matrix([[0, 0, 1, 0], [0, 0, 0, 1],
                           [-k / mr, k / mr, -(br + bc) / mr, bc / mr],
                           [k / md, -k / md, bc / md, -(bd + bc) / md]])
            b = mp.matrix([0, 0, 1 / mr, 0])
        n = a.rows

        def aug(sigma):
            big = mp.zeros(n + 1, n + 1)
            for i in range(n):
                for j in range(n):
                    big[i, j] = a[i, j] * sigma
                big[i, n] = b[i] * sigma
            e = mp.expm(big)
            return e[0:n, 0:n], e[0:n, n]

        d, f = split(device.delay_samples)
        f = mp.mpf(f)
        phi, _ = aug(mp.mpf(1))
        e0, g0 = aug(1 - f)
        g1 = e0 * aug(f)[1] if f > 0 else mp.zeros(n, 1)
        alpha, beta = mp.mpf(stiffness) * t * t / m, mp.mpf(damping) * t / m
        size = n + 1 + d + 1
        q = mp.zeros(size, size)
        u = [mp.mpf(0)] * size                      # u[k] as a row over [x, y[k−1], u[k−1], …, u[k−d−1]]
        u[0] = -(alpha + beta)
        u[n] = beta
        buf = n + 1
        for i in range(n):
            for j in range(n):
                q[i, j] = phi[i, j]
            if d == 0:
                for j in range(size):
                    q[i, j] += g0[i] * u[j]
            else:
                q[i, buf + d - 1] += g0[i]
            q[i, buf + d] += g1[i]
        q[n, 0] = 1
        for j in range(size):
            q[buf, j] = u[j]
        for j in range(1, d + 1):
            q[buf + j, buf + j - 1] = 1
        return max(abs(z) - 1 for z in mp.eig(q, left=False, right=False))
