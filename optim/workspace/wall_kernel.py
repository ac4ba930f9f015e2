"""The wall plant's exact scan compiled (numba): every positive real crossing of H(θ) for G_n = Σ c_i/(s(s + λ_i)).

The same steps, in the same order, as the Python scan it replaces (optim.stability.crossovers.positive_real_crossings
on optim.workspace.wall_plant's H, kept as the twin and the oracle): H on the scan's initial grid, every interval
where arg H turns by more than a quarter radian bisected (up to 60 times; each interval's decision depends only on
its own ends, so a depth-first bisection makes the same samples as the Python's rounds), each sign change of Im H
with Re H > 0 on either side solved by the same Illinois regula falsi to 4 ulp, an exact zero on a sample, and the
Nyquist point.  Each mode's response is optim.workspace.normal_kernel.mode_response (RigidZOH.response's
operations); numba's complex quotient is CPython's (Smith's, dividing by the denominator) where numpy multiplies
by its inverse, so a value may differ from the Python's in the last bits: tests/optim/workspace/test_wall_kernel.py
holds the two to 1e-12 relative.

A near-tangency (arg H within 0.05 rad of 0 at a local minimum of |arg H| without a sign change: two crossings
between two samples, which the Python resolves by a bounded minimisation) is not compiled: the kernel says so and
the caller runs the Python scan (the same answer, at the Python's speed).
"""

from __future__ import annotations

import math

import numpy as np

from optim.stability.compiled import kernel
from optim.stability.crossovers import LIN_STEP, LOG_END, LOG_MIN_SAMPLES, LOG_PER_DECADE, STEPS_PER_DELAY_TURN

from .normal_kernel import weighted_response

__all__ = ["wall_crossings", "plain_scan_grid", "compile_kernels", "KIND_STIFFNESS", "KIND_DAMPER"]

#: H(θ) = −1/G_n(θ) + β(e^{−jθ} − 1): the stiffness loop (K > 0 crossovers)
KIND_STIFFNESS = 0
#: H(θ) = (−1/G_n(θ))/(1 − e^{−jθ}): the damper-only loop (its smallest positive crossing is β_max)
KIND_DAMPER = 1

_EPS = 2.220446049250313e-16
_MAX_ARG_STEP = 0.25
_MAX_REFINE_ROUNDS = 60


@kernel
def plain_scan_grid(theta_min, delay_samples):
    """optim.stability.crossovers.scan_grid(θ_min, d, ()) compiled: the log part to max(LOG_END, 10 θ_min), then
    the linear part to π, by numpy's geomspace and linspace formulas (numpy's vectorised power and log10 may round
    a sample 1 ulp apart: the crossings found are the same, refined to 4 ulp)."""
    theta_lin = max(LOG_END, theta_min * 10)
    n1 = max(LOG_MIN_SAMPLES, int(LOG_PER_DECADE * math.log10(theta_lin / theta_min)) + 2)
    step = min(LIN_STEP, math.pi / (STEPS_PER_DELAY_TURN * (delay_samples + 1.0)))
    n2 = int(math.ceil((math.pi - theta_lin) / step)) + 1
    out = np.empty(n1 + n2 - 1)
    ls, le = math.log10(theta_min), math.log10(theta_lin)
    st = (le - ls) / (n1 - 1)
    for i in range(n1):
        out[i] = 10.0 ** (float(i) * st + ls)
    out[0] = theta_min
    out[n1 - 1] = theta_lin
    st2 = (math.pi - theta_lin) / (n2 - 1)
    for i in range(1, n2):
        out[n1 - 1 + i] = float(i) * st2 + theta_lin
    out[n1 + n2 - 2] = math.pi
    return out


@kernel
def _h(wts, modes, theta, beta, kind):
    """H(θ) of the wall loop (``kind``), G_n = Σ wts_i R_i(θ) (the normalised weights c_i·m_e)."""
    g, zm1 = weighted_response(wts, modes, theta)
    inv = -1.0 / g
    em1 = zm1.conjugate()                       # e^{−jθ} − 1 (numpy's expm1(−jθ))
    if kind == KIND_STIFFNESS:
        return inv + complex(beta * em1.real, beta * em1.imag)
    return inv / (-em1)


@kernel
def _sign(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x


@kernel
def _illinois(wts, modes, beta, kind, a, b, fa, fb):
    """The root of Im H in [a, b] (crossovers.solve_brackets, one bracket: the same steps)."""
    side = 0
    tol = 4.0 * _EPS
    for it in range(200):
        if not abs(b - a) > tol * max(abs(a), abs(b)):
            break
        if fb != fa:
            x = b - fb * (b - a) / (fb - fa)
        else:
            x = 0.5 * (a + b)
        lo, hi, mid = min(a, b), max(a, b), 0.5 * (a + b)
        bad = (not (x >= lo and x <= hi)) or (it % 4 == 3)
        m = 2.0 * _EPS * hi
        if bad:
            x = mid
        elif x - lo < m:
            x = min(lo + m, mid)
        elif hi - x < m:
            x = max(hi - m, mid)
        fx = _h(wts, modes, x, beta, kind).imag
        done = fx == 0.0
        left = _sign(fx) == _sign(fa)
        if left and side == 1:
            fb = fb / 2.0
        if (not left) and side == -1:
            fa = fa / 2.0
        if left:
            a, fa = x, fx
        else:
            b, fb = x, fx
        side = 1 if left else -1
        if done:
            a, b, fa, fb = x, x, 0.0, 0.0
    return a if abs(fa) <= abs(fb) else b


@kernel
def wall_crossings(wts, modes, grid, beta, kind):
    """(angles, values, ok): every θ in [grid[0], π] where H is real and positive, with H there (sorted by θ);
    ``ok`` False when a near-tangency needs the Python scan (the arrays are then empty)."""
    g0 = grid.shape[0]
    ts = [grid[0]]
    vs = [_h(wts, modes, grid[0], beta, kind)]
    # depth-first bisection of each initial interval, left half first: the samples come out in order
    st_lo = np.empty(_MAX_REFINE_ROUNDS + 2)
    st_hi = np.empty(_MAX_REFINE_ROUNDS + 2)
    st_vlo = np.empty(_MAX_REFINE_ROUNDS + 2, dtype=np.complex128)
    st_vhi = np.empty(_MAX_REFINE_ROUNDS + 2, dtype=np.complex128)
    st_dep = np.empty(_MAX_REFINE_ROUNDS + 2, dtype=np.int64)
    vprev = vs[0]
    for j in range(1, g0):
        vj = _h(wts, modes, grid[j], beta, kind)
        top = 0
        st_lo[0], st_hi[0], st_vlo[0], st_vhi[0], st_dep[0] = grid[j - 1], grid[j], vprev, vj, 0
        top = 1
        while top > 0:
            top -= 1
            lo, hi, vlo, vhi, dep = st_lo[top], st_hi[top], st_vlo[top], st_vhi[top], st_dep[top]
            q = vhi / vlo if vlo != 0 else complex(math.nan, math.nan)
            turn = abs(math.atan2(q.imag, q.real))
            bad = (turn > _MAX_ARG_STEP) or vhi == 0 or vlo == 0
            bad = bad and (hi - lo) > 1e-14 * hi and dep < _MAX_REFINE_ROUNDS
            if not bad:
                ts.append(hi)
                vs.append(vhi)
                continue
            mid = 0.5 * (lo + hi)
            vmid = _h(wts, modes, mid, beta, kind)
            # right half below the left on the stack: the left is done first
            st_lo[top], st_hi[top], st_vlo[top], st_vhi[top], st_dep[top] = mid, hi, vmid, vhi, dep + 1
            st_lo[top + 1], st_hi[top + 1], st_vlo[top + 1], st_vhi[top + 1], st_dep[top + 1] = lo, mid, vlo, vmid, \
                dep + 1
            top += 2
        vprev = vj
    n = len(ts)
    angles = []
    values = []
    empty = np.empty(0)
    # a near-tangency: the Python scan decides
    for i in range(1, n - 1):
        a0 = math.atan2(vs[i - 1].imag, vs[i - 1].real)
        a1 = math.atan2(vs[i].imag, vs[i].real)
        a2 = math.atan2(vs[i + 1].imag, vs[i + 1].real)
        if (abs(a1) <= abs(a0) and abs(a1) <= abs(a2) and abs(a1) < 0.05 and vs[i].real > 0
                and _sign(a0) == _sign(a2) and _sign(a1) == _sign(a2)):
            return empty, empty, False
    for i in range(n - 1):
        im0, im1 = vs[i].imag, vs[i + 1].imag
        if _sign(im0) * _sign(im1) < 0 and (vs[i].real > 0 or vs[i + 1].real > 0):
            x = _illinois(wts, modes, beta, kind, ts[i], ts[i + 1], im0, im1)
            v = _h(wts, modes, x, beta, kind).real
            if v > 0:
                angles.append(x)
                values.append(v)
    for i in range(1, n - 1):            # an exact zero on a sample
        if vs[i].imag == 0.0 and vs[i].real > 0:
            angles.append(ts[i])
            values.append(vs[i].real)
    v_pi = _h(wts, modes, math.pi, beta, kind)
    out_a = []
    out_v = []
    for k in range(len(angles)):
        if v_pi.real > 0 and not (math.pi - angles[k] > 1e-9):
            continue
        out_a.append(angles[k])
        out_v.append(values[k])
    if v_pi.real > 0:
        out_a.append(math.pi)
        out_v.append(v_pi.real)
    a_arr = np.array(out_a) if len(out_a) else np.empty(0)
    v_arr = np.array(out_v) if len(out_v) else np.empty(0)
    order = np.argsort(a_arr, kind="mergesort")
    return a_arr[order], v_arr[order], True


def compile_kernels() -> None:
    """Compile (or load from numba's cache) on a made-up plant: the first workspace analysis then runs at speed."""
    from models.discretize import RigidZOH

    from .normal_kernel import mode_numbers

    modes = mode_numbers([RigidZOH(1e-3, 0, 0.5), RigidZOH(2e-3, 0, 0.5)])
    grid = plain_scan_grid(1e-5, 0.5)
    wall_crossings(np.array([0.5, 0.5]), modes, grid, 0.0, KIND_STIFFNESS)
    wall_crossings(np.array([0.5, 0.5]), modes, grid, 0.0, KIND_DAMPER)
