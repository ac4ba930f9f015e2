"""The worst-normal search's inner loop compiled (numba): the smallest positive crossover K of many normals at one pose.

The same steps as optim.workspace.normal_search._PoseLoop.critical (its Python twin, kept as the oracle): K(θ) of
each normal on the scan grid's window from the modes' responses there, every sign change of Im K with Re K > 0 on
either side, a fixed number of secant steps on Im K with each mode's response evaluated at the new θ in closed form
(models.discretize.RigidZOH.response), and the smallest positive Re K; θ = π's value when the window reaches it.
The per-normal sums and the complex arithmetic are written out (on the grid −1/(T²g) as −ḡ/(T²|g|²)), so a value
may differ from the twin's in the last bits: tests/optim/workspace/test_normal_kernel.py holds the two to
1e-12 relative.

Why compiled: the polish evaluates ~15 levels of 3 × 49 normals; in numpy each call is ~60 small array operations
and the secant's per-mode response calls (~1.2 ms), compiled it is the arithmetic alone.
"""

from __future__ import annotations

import math

import numpy as np

from models.discretize import RigidZOH
from optim.stability.compiled import kernel

__all__ = ["mode_numbers", "mode_response", "circle_point", "weighted_response", "critical_kernel", "compile_kernels"]

# the columns of a mode's numbers
(AT_FRAC, AT_A, AT_C, AT_OMP, AT_PHI12, AT_G0P, AT_G0V, AT_G1P, AT_G1V, AT_D, AT_NYQ) = range(11)


def mode_numbers(plants: list[RigidZOH]) -> np.ndarray:
    """One row per mode: whether the delay is fractional, the whole-sample numerator's a, c, the closed-form ZOH
    coefficients, the whole delay d and 1/G(−1) (NaN where the complex formula stands)."""
    rows = []
    for p in plants:
        omp, phi12, g0p, g0v, g1p, g1v, _ = p.coefficients()
        a, c = p.f0_numerator()
        nyq = p.inverse_at_nyquist()
        rows.append([1.0 if p.f != 0.0 else 0.0, a, c, omp, phi12, g0p, g0v, g1p, g1v, float(p.d),
                     math.nan if nyq is None else nyq])
    return np.array(rows, dtype=float).reshape(len(plants), 11)


@kernel
def mode_response(v, theta, z, zm1, zinv, lead):
    """R(θ) of one mode (a row of :func:`mode_numbers`) as RigidZOH.response(θ): the ZOH numerator over
    (z − 1)(z − 1 + ω') with the delay's phase ``lead``, the Nyquist value in closed form; z, z − 1, 1/z and the
    delay's phase are the caller's (shared by the modes)."""
    if theta == math.pi and not math.isnan(v[AT_NYQ]):
        return complex(1.0, 0.0) / complex(v[AT_NYQ], 0.0)
    den = zm1 * (zm1 + v[AT_OMP])
    if v[AT_FRAC] == 0.0:
        num = v[AT_A] * (z + 1.0) + v[AT_C]
    else:
        gpos = v[AT_G0P] + v[AT_G1P] * zinv
        gvel = v[AT_G0V] + v[AT_G1V] * zinv
        num = gpos * ((z - 1.0) + v[AT_OMP]) + v[AT_PHI12] * gvel
    return 1.0 / (den * lead / num)


@kernel
def circle_point(theta, d):
    """(z, z − 1, 1/z, the delay's phase e^{jdθ}) at z = e^{jθ}, shared by the modes of one plant (d: the modes'
    whole delay in samples, mode_numbers' AT_D); z − 1 = −2 sin²(θ/2) + j sin θ, its conjugate e^{−jθ} − 1."""
    sn = math.sin(theta)
    z = complex(math.cos(theta), sn)
    sh = math.sin(0.5 * theta)
    zm1 = complex(-2.0 * sh * sh, sn)
    dt = d * theta
    lead = complex(math.cos(dt), math.sin(dt))
    return z, zm1, 1.0 / z, lead


@kernel
def weighted_response(weights, modes, theta):
    """(Σ weights_i R_i(θ), z − 1): the plant along one normal, each R_i by :func:`mode_response`."""
    z, zm1, zinv, lead = circle_point(theta, modes[0, AT_D])
    g = complex(0.0, 0.0)
    for i in range(modes.shape[0]):
        g += weights[i] * mode_response(modes[i], theta, z, zm1, zinv, lead)
    return g, zm1


@kernel
def _k(crow, modes, theta, t, b):
    """K(θ) = −1/(T²·Σ c_i R_i(θ)) − B(1 − e^{−jθ})/T of one normal (weights ``crow``), each R_i as
    RigidZOH.response(θ) (the modes share the delay, so z, z − 1 and the delay's phase are computed once)."""
    g, zm1 = weighted_response(crow, modes, theta)
    one_minus = -zm1.conjugate()                  # 1 − e^{−jθ}
    return -1.0 / (t * t * g) - b * one_minus / t


@kernel
def critical_kernel(c, r_win, grid, modes, t, b, steps, reaches_pi):
    """(the smallest positive crossover K of each normal [N/m], inf where none; the grid column of the lowest
    bracket, −1 where none).  ``c`` normals × modes weights, ``r_win`` modes × G responses on the window ``grid``."""
    n, m = c.shape
    g_len = grid.shape[0]
    best = np.full(n, np.inf)
    lowest, low_col, first_col = np.inf, -1, -1
    im = np.empty(g_len)
    re = np.empty(g_len)
    r_re, r_im = r_win.real.copy(), r_win.imag.copy()
    damp_re = np.empty(g_len)      # B(1 − e^{−jθ})/T on the grid
    damp_im = np.empty(g_len)
    for j in range(g_len):
        sh = math.sin(0.5 * grid[j])
        damp_re[j] = b * (2.0 * sh * sh) / t
        damp_im[j] = b * math.sin(grid[j]) / t
    t2 = t * t
    for row in range(n):
        for j in range(g_len):      # −1/(T²g) as −ḡ/(T²|g|²): real arithmetic, no complex quotient
            gr, gi = 0.0, 0.0
            for i in range(m):
                gr += c[row, i] * r_re[i, j]
                gi += c[row, i] * r_im[i, j]
            den = t2 * (gr * gr + gi * gi)
            re[j] = -gr / den - damp_re[j]
            im[j] = gi / den - damp_im[j]
        for j in range(g_len - 1):
            if not (np.sign(im[j]) * np.sign(im[j + 1]) < 0 and (re[j] > 0 or re[j + 1] > 0)):
                continue
            if first_col < 0:
                first_col = j
            a, bb = grid[j], grid[j + 1]
            fa, fb = im[j], im[j + 1]
            for _ in range(steps):
                x = bb - fb * (bb - a) / (fb - fa)
                lo, hi = min(a, bb), max(a, bb)
                if x < lo:
                    x = lo
                elif x > hi:
                    x = hi
                fx = _k(c[row], modes, x, t, b).imag
                if np.sign(fx) == np.sign(fa):
                    a, fa = x, fx
                else:
                    bb, fb = x, fx
            x = a if abs(fa) < abs(fb) else bb
            kx = _k(c[row], modes, x, t, b).real
            if not kx > 0:
                kx = np.inf
            if kx < best[row]:
                best[row] = kx
            if kx < lowest:
                lowest, low_col = kx, j
        if reaches_pi and re[g_len - 1] > 0 and re[g_len - 1] < best[row]:
            best[row] = re[g_len - 1]
    return best, (low_col if low_col >= 0 else first_col)


def compile_kernels() -> None:
    """Compile (or load from numba's cache) on a made-up pose: the first workspace analysis then runs at speed."""
    plants = [RigidZOH(1e-3, 0, 0.0), RigidZOH(2e-3, 1, 0.5)]
    grid = np.linspace(0.01, math.pi, 16)
    r = np.stack([p.response(grid) for p in plants])
    critical_kernel(np.ones((2, 2)), r, grid, mode_numbers(plants), 1e-3, 0.0, 2, True)
