"""An independent closed loop of a rendered wall C(z) = K + B·V(z) + M·A(z), for the band tests past B_max.

Shares no code with zwidth's scan (optim.stability.rendered) nor with verify's closed loop
(optim.stability.closed_loop_rendered): the plant is tests/optim/independent.py's (physical coordinates, its own ZOH,
the delay as a shift register of past forces); the filter's coefficients are written out again here from its
specification; the controller P(w)/D(w) (w = z⁻¹) is realised by scipy.signal.tf2ss and the loop closed as one
state matrix whose spectral radius numpy gives."""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
from scipy import signal

from models.velocity_filter import BackwardDifference, LowPass, MovingAverage, TransferFunctionFilter
from tests.optim.independent import discretise, physical_model


def velocity_polynomials(spec, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(T·N, D) of V = N/D in ascending powers of w = z⁻¹."""
    if spec is None or isinstance(spec, BackwardDifference):
        return np.array([1.0, -1.0]), np.array([1.0])
    if isinstance(spec, LowPass):
        if spec.order == 1:
            x = 2.0 * math.pi * spec.cutoff_hz * t
            # 1 − a by expm1: the subtraction loses u/x relative, which a wall near B_max amplifies by its
            # cancellation (1e6 and more): the filter would not be the specified one to the digits the check needs
            return -math.expm1(-x) * np.array([1.0, -1.0]), np.array([1.0, -math.exp(-x)])
        b, a = signal.butter(2, 2.0 * spec.cutoff_hz * t)          # cutoff as a fraction of Nyquist
        return np.convolve([1.0, -1.0], b / a[0]), a / a[0]
    if isinstance(spec, MovingAverage):
        n = spec.samples
        out = np.zeros(n + 1)
        out[0], out[-1] = 1.0 / n, -1.0 / n
        return out, np.array([1.0])
    assert isinstance(spec, TransferFunctionFilter)
    den = np.asarray(spec.denominator, dtype=float)
    return np.asarray(spec.numerator, dtype=float) * t / den[0], den / den[0]


def rendered_radius(device, spec, mass: float, stiffness: float, damping: float) -> float:
    """The spectral radius of the closed loop with the wall (K [N/m], B [N·s/m], M [kg], filter ``spec``)."""
    m, t = device.mass, device.sample_time
    alpha, beta, mu = stiffness * t * t / m, damping * t / m, mass / m
    nv, dv = velocity_polynomials(spec, t)
    size = max(dv.size, nv.size + 1)
    p, d = np.zeros(size), np.zeros(size)
    p[:dv.size] += alpha * dv
    p[:nv.size] += (beta + mu) * nv
    p[1:nv.size + 1] -= mu * nv
    d[:dv.size] = dv
    # P(w)/D(w) = P(z)/D(z) with both multiplied by z^(size−1): the ascending w-coefficients are descending in z
    ac, bc, cc, dc = signal.tf2ss(p, d)
    a, b, c = physical_model(device)
    phi, g0, g1, nd = discretise(a, b, device.delay_samples)
    n, nc = phi.shape[0], ac.shape[0]
    buf = n + nc
    total = buf + nd + 1                  # buf[j] = u[k−1−j], j = 0..d
    q = np.zeros((total, total))
    u = np.zeros(total)                   # u[k] = −(Cc·xc + Dc·y), y = c·x
    u[:n] = -float(dc[0, 0]) * c
    u[n:buf] = -cc[0]
    q[:n, :n] = phi
    if nd == 0:
        q[:n, :] += np.outer(g0, u)
    else:
        q[:n, buf + nd - 1] += g0
    q[:n, buf + nd] += g1
    q[n:buf, :n] = np.outer(bc[:, 0], c)
    q[n:buf, n:buf] = ac
    q[buf, :] = u
    for j in range(1, nd + 1):
        q[buf + j, buf + j - 1] = 1.0
    return float(np.max(np.abs(np.linalg.eigvals(q))))


def rendered_radius_excess_mp(device, spec, mass: float, stiffness: float, damping: float, digits: int = 50):
    """max |z| − 1 of the same closed loop in ``digits``-digit mpmath (the filter's double coefficients taken as
    exact): the plant's ZOH and fractional delay from mpmath matrix exponentials in physical coordinates, the
    controller as its difference equation u[k] = −Σ P_i y[k−i] − Σ_{i≥1} D_i u[k−i] on shift registers of past
    positions and past forces, the eigenvalues by mp.eig.  For short delays and filters (the matrix grows with them)."""
    from tests.optim.independent import split

    nv, dv = velocity_polynomials(spec, device.sample_time)
    with mp.workdps(digits):
        m, t = mp.mpf(device.mass), mp.mpf(device.sample_time)
        a_d, b_d, _ = physical_model(device)          # dimensionless A, B (double), rebuilt in mp below
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
        assert n == a_d.shape[0] and len(b_d) == n

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
        alpha, beta, mu = mp.mpf(stiffness) * t * t / m, mp.mpf(damping) * t / m, mp.mpf(mass) / m
        size_c = max(len(dv), len(nv) + 1)
        p = [mp.mpf(0)] * size_c
        for i, c_ in enumerate(dv):
            p[i] += alpha * mp.mpf(c_)
        for i, c_ in enumerate(nv):
            p[i] += (beta + mu) * mp.mpf(c_)
            p[i + 1] -= mu * mp.mpf(c_)
        den = [mp.mpf(c_) for c_ in dv]
        npast = size_c - 1                               # y[k−1] … y[k−npast]
        chain = max(d + 1, len(den) - 1)                 # u[k−1] … u[k−chain]
        iy, iu = n, n + npast
        size = n + npast + chain
        u = [mp.mpf(0)] * size                           # u[k] as a row over the state
        u[0] = -p[0]                                     # y[k] = x_0 (the motor position)
        for i in range(1, size_c):
            u[iy + i - 1] -= p[i]
        for i in range(1, len(den)):
            u[iu + i - 1] -= den[i]
        q = mp.zeros(size, size)
        for i in range(n):
            for j in range(n):
                q[i, j] = phi[i, j]
            if d == 0:
                for j in range(size):
                    q[i, j] += g0[i] * u[j]
            else:
                q[i, iu + d - 1] += g0[i]
            q[i, iu + d] += g1[i]
        if npast:
            q[iy, 0] = 1
            for j in range(1, npast):
                q[iy + j, iy + j - 1] = 1
        for j in range(size):
            q[iu, j] = u[j]
        for j in range(1, chain):
            q[iu + j, iu + j - 1] = 1
        return max(abs(z) - 1 for z in mp.eig(q, left=False, right=False))
