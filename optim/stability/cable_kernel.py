"""The cable brackets compiled (numba): K_cr(B) and β_max of a damped cable without a scan, at compiled speed (issue 32).

The same operations, in the same order, as the Python they compile, which stays the twin and the oracle
(optim.stability.cable_brackets' ``cable_min_crossing`` with optim.stability.cable_points' evaluations; their module
docstrings give the maths): the modal response 1/G_n, F, F' and R at one angle (with the window that picks F's
branch without the factors' arguments), the bounds of R, F' and (log R)' on a piece, the bracketed Newton on F and on
log R, the polish on Im H (Illinois to 4 ulp) and the pieces' loop.  Complex products and quotients are numba's,
which reproduce CPython's (as optim.stability.rigid_kernel's do), and ``max``/``min`` are written out with Python's
choice of operand.  No ``fastmath``.  tests/optim/stability/test_cable_kernel.py holds the kernel to the Python, bit
for bit (θ, α and the pieces examined), on random damped cables, whole and fractional delays, B = 0, B below β_max
and the damper-only loop.

The Python keeps the device's β-free work between calls (its memo); the kernel recomputes it (a point costs ≈ 0.1 µs
compiled): the same values, so the same bits.

The loop travels as arrays (optim.stability.cable_loop.loop_arrays, built once per device with its CableLoop): per factor (Q's numerator's
c_k, then its denominator's ζ_i) a row of reals (sign, |c|, gap, err, inside, arg(−c), ω-bounds, the four angles,
NaN where None) and a row of complex (w, c, 1/(−c)); the modal form's 3 modes (λ, r0, r1, e12, c2) then c1, g0₁,
g1₁; the numbers s, arg L, |L|, d and whether a factor is near the unit circle; and the split angles.
"""

from __future__ import annotations

import math

import numpy as np

from optim.stability.cable_loop import MAX_NEAR_ERROR, CableLoop
from optim.stability.compiled import kernel

__all__ = ["min_crossing", "batch_rows", "cable_min_crossing_compiled", "compile_kernels", "MAX_PIECES", "inverse_response"]

_EPS = 2.220446049250313e-16
_TWO_PI = 2.0 * math.pi
_HALF_PI = 0.5 * math.pi
_PI = math.pi
#: pieces examined before giving up (cable_brackets.MAX_PIECES)
MAX_PIECES = 20_000
_PAD = 1e-9
_NOSKIP = -(1 << 62)

# columns of the factors' real rows
(R_SIGN, R_MAG, R_GAP, R_ERR, R_INSIDE, R_BASE, R_OMLO, R_OMHI, R_NEAR, R_FAR, R_SMAX, R_SMIN, R_FERR) = range(13)
# columns of their complex rows
(C_W, C_C, C_INV) = range(3)
# the loop's numbers
(N_S, N_LEAD_ARG, N_LEAD_ABS, N_D, N_NEAR) = range(5)


# ---------------------------------------------------------------------------------------------------- evaluations

@kernel
def _inv_response(modal, d, t):
    """1/G_n(e^{jθ}) by the modal form (cable_loop.inverse_response_at)."""
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    zm1 = complex(-2.0 * sh * sh, st)
    zinv = complex(math.cos(t), -st)
    acc_e = 0j
    acc_c = 0j
    for i in range(3):
        lam, r0, r1, e12, c2 = modal[5 * i], modal[5 * i + 1], modal[5 * i + 2], modal[5 * i + 3], modal[5 * i + 4]
        y = (r0 + zinv * r1) / (zm1 - lam)
        acc_e += y * e12
        acc_c += y * c2
    c1, g0_1, g1_1 = modal[15], modal[16], modal[17]
    x1 = (g0_1 + zinv * g1_1 + acc_e) / zm1
    dt = d * t
    g = (c1 * x1 + acc_c) * complex(math.cos(dt), -math.sin(dt))
    return 1.0 / g


#: 1/G_n by the modal form, compiled (optim.stability.rendered_rigid refines a filtered cable wall's roots on it)
inverse_response = _inv_response


@kernel
def _expm1j(t):
    sh = math.sin(0.5 * t)
    return complex(-2.0 * sh * sh, math.sin(t))


@kernel
def _h_at(modal, d, beta, damper, t):
    """H(θ) (cable_points.h_at)."""
    inv = _inv_response(modal, d, t)
    if damper:
        return -inv / (-_expm1j(-t))
    return -inv + beta * _expm1j(-t)


@kernel
def _parts(fr, fc, modal, nums, t):
    """cable_points.parts: (φ principal − θ/2, (arg Q)' − ½, (log R)', R, e^{jθ} − 1, e^{−jθ})."""
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    ct = math.cos(t)
    zm1 = complex(-2.0 * sh * sh, st)
    zc = complex(ct, -st)
    acc = 0j
    nf = fr.shape[0]
    for i in range(nf):
        if fr[i, R_SIGN] > 0.0:
            acc += 1.0 / (zm1 - fc[i, C_W])
    for i in range(nf):
        if fr[i, R_SIGN] < 0.0:
            acc -= 1.0 / (zm1 - fc[i, C_W])
    zs = complex(ct, st) * acc
    q = _inv_response(modal, nums[N_D], t) / (1.0 - zc)
    return math.atan2(q.imag, q.real) - 0.5 * t, nums[N_S] - 0.5 + zs.real, -zs.imag, abs(q), zm1, zc


@kernel
def _branch(fr, fc, nums, t, zm1, zc, exact):
    """cable_points.branch: k with exact + 2πk the continuous φ."""
    phi = (nums[N_S] - 0.5) * t - nums[N_LEAD_ARG]
    nf = fr.shape[0]
    for sgn in (1.0, -1.0):
        for i in range(nf):
            if fr[i, R_SIGN] != sgn:
                continue
            v = zm1 - fc[i, C_W]
            if fr[i, R_INSIDE] != 0.0:
                p = v * zc
                term = t + math.atan2(p.imag, p.real)
            else:
                p = v * fc[i, C_INV]
                term = fr[i, R_BASE] + math.atan2(p.imag, p.real)
            if sgn > 0.0:
                phi += term
            else:
                phi -= term
    return round((phi - exact) / _TWO_PI)


@kernel
def _assemble(beta, cslope, t, phi_u, dphi0, dlr, r):
    phi = phi_u + cslope * t
    dphi = dphi0 + cslope
    if beta == 0.0:
        return phi, dphi, r
    g = beta * math.cos(0.5 * t) / r
    if g >= 1.0:
        return phi - 0.5 * math.pi, dphi, r
    root = math.sqrt((1.0 - g) * (1.0 + g))
    return phi - math.asin(g), dphi + g / root * (0.5 * math.tan(0.5 * t) + dlr), r


@kernel
def _point(fr, fc, modal, nums, beta, cslope, t, has_window, w_lo, w_hi):
    """cable_points.point: (F, F', R) at θ = t (``has_window``: F known to lie in [w_lo, w_hi])."""
    exact, dphi0, dlr, r, zm1, zc = _parts(fr, fc, modal, nums, t)
    found = False
    k = 0
    if has_window:
        pad = 1e-6 * (1.0 + abs(w_lo) + abs(w_hi))
        g = beta * math.cos(0.5 * t) / r
        if beta == 0.0:
            sub = 0.0
        elif g >= 1.0:
            sub = 0.5 * math.pi
        else:
            sub = math.asin(g)
        base = exact + cslope * t - sub
        k = math.ceil((w_lo - pad - base) / _TWO_PI)
        found = k == math.floor((w_hi + pad - base) / _TWO_PI)
    if not found:
        k = _branch(fr, fc, nums, t, zm1, zc, exact)
    return _assemble(beta, cslope, t, exact + _TWO_PI * k, dphi0, dlr, r)


@kernel
def _base(fr, fc, modal, nums, t):
    """cable_points.Point.base: (φ unwrapped, (arg Q)' − ½, (log R)', R)."""
    exact, dphi0, dlr, r, zm1, zc = _parts(fr, fc, modal, nums, t)
    return exact + _TWO_PI * _branch(fr, fc, nums, t, zm1, zc, exact), dphi0, dlr, r


@kernel
def _r_at(modal, nums, t):
    return abs(_inv_response(modal, nums[N_D], t) / (1.0 - complex(math.cos(t), -math.sin(t))))


@kernel
def _log_r(fr, fc, modal, nums, t):
    """cable_points.log_r: (log R, (log R)')."""
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    ct = math.cos(t)
    zm1 = complex(-2.0 * sh * sh, st)
    acc = 0j
    nf = fr.shape[0]
    for i in range(nf):
        if fr[i, R_SIGN] > 0.0:
            acc += 1.0 / (zm1 - fc[i, C_W])
    for i in range(nf):
        if fr[i, R_SIGN] < 0.0:
            acc -= 1.0 / (zm1 - fc[i, C_W])
    q = _inv_response(modal, nums[N_D], t) / (1.0 - complex(ct, -st))
    return math.log(abs(q)), -(complex(ct, st) * acc).imag


@kernel
def _dist_sin(fr, fc, t, dist, sin):
    """cable_points.Point: per factor |e^{jθ} − c| and |c| sin(θ − arg c), into ``dist``, ``sin``."""
    zm1 = _expm1j(t)
    z = zm1 + 1.0
    for i in range(fr.shape[0]):
        dist[i] = abs(zm1 - fc[i, C_W])
        sin[i] = (z * fc[i, C_C].conjugate()).imag


# ---------------------------------------------------------------------------------------------------- solvers

@kernel
def _newton(fr, fc, modal, nums, beta, cslope, level, a, b, fa, fb, x, up):
    """cable_points.newton."""
    lev = level if up else -level
    lo, hi = a, b
    f_lo, f_hi = fa, fb
    for _ in range(200):
        if not (lo < x < hi):
            x = math.sqrt(lo * hi) if lo > 0.0 and hi > 8.0 * lo else 0.5 * (lo + hi)
        if up:
            f, df, _r = _point(fr, fc, modal, nums, beta, cslope, x, True, f_lo, f_hi)
        else:
            f, df, _r = _point(fr, fc, modal, nums, beta, cslope, x, True, f_hi, f_lo)
        if up:
            fx, dfx = f, df
        else:
            fx, dfx = -f, -df
        if fx == lev:
            return x
        if fx < lev:
            lo, f_lo = x, f
        else:
            hi, f_hi = x, f
        if hi - lo <= 1e-12 * hi:
            return x
        if dfx > 0.0:
            step = (fx - lev) / dfx
            u = -step / x
            xn = x * math.exp(u) if hi > 4.0 * lo and -50.0 < u < 50.0 else x - step
        else:
            xn = -math.inf
        if abs(xn - x) <= 1e-12 * x and lo <= xn <= hi:
            return xn
        x = xn
    return x


@kernel
def _solve_log_r(fr, fc, modal, nums, neg, level, lo, hi, x):
    """fast_rigid.bracketed_newton on log R (``neg``: on −log R) to 1e-12 (cable_brackets._solve)."""
    for _ in range(200):
        if not (lo < x < hi):
            x = math.sqrt(lo * hi) if lo > 0.0 and hi > 8.0 * lo else 0.5 * (lo + hi)
        fx, dfx = _log_r(fr, fc, modal, nums, x)
        if neg:
            fx, dfx = -fx, -dfx
        if fx == level:
            return x
        if fx < level:
            lo = x
        else:
            hi = x
        if hi - lo <= 1e-12 * hi:
            return x
        step = (fx - level) / dfx if dfx > 0.0 else math.inf
        xn = x - step
        if lo <= xn <= hi and abs(step) <= 1e-12 * x:
            return xn
        x = xn
    return x


@kernel
def _polish(fr, fc, modal, nums, beta, damper, t0, a, b, level, up):
    """cable_points.polish: (ok, θ, Re H) of the root of Im H next to t0."""
    d = nums[N_D]
    cslope = 0.5 if damper else 0.0
    h0 = _h_at(modal, d, beta, damper, t0)
    f0 = h0.imag
    if f0 == 0.0:
        return True, t0, h0.real
    have = False
    ba = bb = fba = fbb = 0.0
    hba = hbb = 0j
    for w in (1e-12, 1e-10, 1e-8, 1e-6, 1e-4):
        lo = t0 * (1.0 - w)
        if a > lo:
            lo = a
        hi = t0 * (1.0 + w)
        if b < hi:
            hi = b
        if math.pi < hi:
            hi = math.pi
        if w > 1e-9:
            plo = _point(fr, fc, modal, nums, beta, cslope, lo, False, 0.0, 0.0)[0]
            phi_ = _point(fr, fc, modal, nums, beta, cslope, hi, False, 0.0, 0.0)[0]
            if not (abs(plo - level) < 1.0 and abs(phi_ - level) < 1.0):
                return False, 0.0, 0.0
        first_hi = (f0 < 0.0) == up
        for j in range(2):
            side_hi = first_hi if j == 0 else not first_hi
            x = hi if side_hi else lo
            hx = _h_at(modal, d, beta, damper, x)
            fx = hx.imag
            if (x > t0 if side_hi else x < t0) and (fx > 0) != (f0 > 0):
                if side_hi:
                    ba, bb, fba, fbb, hba, hbb = t0, x, f0, fx, h0, hx
                else:
                    ba, bb, fba, fbb, hba, hbb = x, t0, fx, f0, hx, h0
                have = True
                break
        if have:
            break
    if not have:
        return False, 0.0, 0.0
    a, b, fa, fb, ha, hb = ba, bb, fba, fbb, hba, hbb
    side = 0
    tol = 4 * _EPS
    for it in range(200):
        if abs(b - a) <= tol * max(abs(a), abs(b)):
            break
        mid = 0.5 * (a + b)
        x = b - fb * (b - a) / (fb - fa) if fb != fa else mid
        lo, hi = (a, b) if a < b else (b, a)
        m = 2.0 * _EPS * hi
        if not (lo <= x <= hi) or it % 8 == 7:
            x = mid
        elif x - lo < m:
            x = lo + m
            if mid < x:
                x = mid
        elif hi - x < m:
            x = hi - m
            if mid > x:
                x = mid
        hx = _h_at(modal, d, beta, damper, x)
        fx = hx.imag
        if fx == 0.0:
            a = b = x
            ha = hb = hx
            fa = fb = 0.0
            break
        if (fx > 0) == (fa > 0):
            if side == 1:
                fb /= 2
            a, fa, ha, side = x, fx, hx, 1
        else:
            if side == -1:
                fa /= 2
            b, fb, hb, side = x, fx, hx, -1
    if abs(fa) <= abs(fb):
        return True, a, ha.real
    return True, b, hb.real


# ---------------------------------------------------------------------------------------------------- bounds

@kernel
def _bounds_r(fr, nums, a, b, da, db, ranges):
    """cable_brackets._bounds_r: (R_min, R_max), each factor's (d_min, d_max) into ``ranges``."""
    rmin = rmax = 1.0 / nums[N_LEAD_ABS]
    for i in range(fr.shape[0]):
        err = fr[i, R_ERR]
        if da[i] <= db[i]:
            mn, mx = da[i] - err, db[i] + err
        else:
            mn, mx = db[i] - err, da[i] + err
        tn = fr[i, R_NEAR]
        if a <= tn <= b:
            mn = fr[i, R_GAP]
        tf = fr[i, R_FAR]
        if a <= tf <= b:
            mx = 1.0 + fr[i, R_MAG] + err
        ranges[i, 0] = mn
        ranges[i, 1] = mx
        if fr[i, R_SIGN] > 0.0:
            rmin *= mn
            rmax *= mx
        else:
            rmin /= mx
            rmax /= mn
    return rmin * (1.0 - _PAD), rmax * (1.0 + _PAD)


@kernel
def _sin_range(fr, i, a, b, sa, sb):
    if sa <= sb:
        mn, mx = sa, sb
    else:
        mn, mx = sb, sa
    ts = fr[i, R_SMAX]
    if a <= ts <= b:
        mx = fr[i, R_MAG]
    ts = fr[i, R_SMIN]
    if a <= ts <= b:
        mn = -fr[i, R_MAG]
    return mn - fr[i, R_ERR], mx + fr[i, R_ERR]


@kernel
def _bounds_d(fr, nums, beta, a, b, sa_v, sb_v, rmin, rmax, ranges, cslope):
    """cable_brackets._bounds_d: (D_lo, D_hi) of F' on [a, b]."""
    s = nums[N_S]
    base = s - 0.5 + cslope
    if beta > 0.0:
        g_lo = beta * math.cos(0.5 * b) / rmax
        g_hi = beta * math.cos(0.5 * a) / rmin
        qa, qb = math.sin(0.25 * a), math.sin(0.25 * b)
        root_hi = math.sqrt(((rmin - beta) + 2.0 * beta * qa * qa) / rmin * (1.0 + g_hi))
        root_lo = math.sqrt(((rmax - beta) + 2.0 * beta * qb * qb) / rmax * (1.0 + g_lo))
        if not root_hi > 0.0:
            return -math.inf, math.inf
        gl, gh = g_lo / root_lo, g_hi / root_hi
        tan_lo = 0.5 * beta * math.sin(0.5 * a) / rmax
        tan_hi = 0.5 * beta * math.sin(0.5 * b) / (rmin * root_hi)
    else:
        gl = gh = tan_lo = tan_hi = 0.0
    lo = hi = base
    plo = phi_ = base
    dl_lo = dl_hi = 0.0
    for i in range(fr.shape[0]):
        mn, mx = ranges[i, 0], ranges[i, 1]
        mn2, mx2 = mn * mn, mx * mx
        om_lo, om_hi = fr[i, R_OMLO], fr[i, R_OMHI]
        p_lo = om_lo / mx2 if om_lo >= 0.0 else om_lo / mn2
        p_hi = om_hi / mn2 if om_hi >= 0.0 else om_hi / mx2
        if gh > 0.0:
            smn, smx = _sin_range(fr, i, a, b, sa_v[i], sb_v[i])
            n_lo = om_lo + (gl * smn if smn >= 0.0 else gh * smn)
            n_hi = om_hi + (gh * smx if smx >= 0.0 else gl * smx)
            t_lo = n_lo / mx2 if n_lo >= 0.0 else n_lo / mn2
            t_hi = n_hi / mn2 if n_hi >= 0.0 else n_hi / mx2
            s_lo = smn / mx2 if smn >= 0.0 else smn / mn2
            s_hi = smx / mn2 if smx >= 0.0 else smx / mx2
        else:
            t_lo, t_hi, s_lo, s_hi = p_lo, p_hi, 0.0, 0.0
        if fr[i, R_SIGN] > 0.0:
            lo += 0.5 + t_lo
            hi += 0.5 + t_hi
            plo += 0.5 + p_lo
            phi_ += 0.5 + p_hi
            dl_lo += s_lo
            dl_hi += s_hi
        else:
            lo -= 0.5 + t_hi
            hi -= 0.5 + t_lo
            plo -= 0.5 + p_hi
            phi_ -= 0.5 + p_lo
            dl_lo -= s_hi
            dl_hi -= s_lo
    lo += tan_lo
    hi += tan_hi
    if gh > 0.0:
        cand = plo + tan_lo + (gl * dl_lo if dl_lo >= 0.0 else gh * dl_lo)
        if cand > lo:
            lo = cand
        cand = phi_ + tan_hi + (gh * dl_hi if dl_hi >= 0.0 else gl * dl_hi)
        if cand < hi:
            hi = cand
    pad = _PAD * (abs(lo) + abs(hi) + s)
    return lo - pad, hi + pad


@kernel
def _dlogr_bounds(fr, a, b, sa_v, sb_v, ranges):
    """cable_brackets._dlogr_bounds."""
    lo = hi = 0.0
    for i in range(fr.shape[0]):
        mn, mx = ranges[i, 0], ranges[i, 1]
        smn, smx = _sin_range(fr, i, a, b, sa_v[i], sb_v[i])
        t_lo = smn / (mx * mx) if smn >= 0.0 else smn / (mn * mn)
        t_hi = smx / (mn * mn) if smx >= 0.0 else smx / (mx * mx)
        if fr[i, R_SIGN] > 0.0:
            lo += t_lo
            hi += t_hi
        else:
            lo -= t_hi
            hi -= t_lo
    pad = _PAD * (abs(lo) + abs(hi))
    return lo - pad, hi + pad


@kernel
def _k_of(beta, t, r):
    if beta == 0.0:
        return 2.0 * math.sin(0.5 * t) * r
    s = math.sin(0.5 * t)
    u = (r - beta) * (r + beta)
    if u <= 0.0:
        return 0.0
    return 2.0 * s * u / (math.sqrt(u + beta * beta * s * s) + beta * s)


@kernel
def _range(fa, fb, dlo, dhi, length):
    """cable_brackets._range."""
    if dlo >= 0.0:
        f_min = fa
    elif dhi <= 0.0:
        f_min = fb
    else:
        t = (fb - fa - dhi * length) / (dlo - dhi)
        if 0.0 > t:
            t = 0.0
        if length < t:
            t = length
        f_min = fa + dlo * t
        o = fb - dhi * (length - t)
        if o > f_min:
            f_min = o
    if dhi <= 0.0:
        f_max = fa
    elif dlo >= 0.0:
        f_max = fb
    else:
        t = (fb - fa - dlo * length) / (dhi - dlo)
        if 0.0 > t:
            t = 0.0
        if length < t:
            t = length
        f_max = fa + dhi * t
        o = fb - dlo * (length - t)
        if o < f_max:
            f_max = o
    pad = 1e-9 * (abs(fa) + abs(fb) + 1.0)
    lo = f_min
    if fa < lo:
        lo = fa
    if fb < lo:
        lo = fb
    hi = f_max
    if fa > hi:
        hi = fa
    if fb > hi:
        hi = fb
    return lo - pad, hi + pad


@kernel
def _first_root(fr, fc, modal, nums, beta, damper, cslope, level0, a, b, fa, fb, up, nyq, skip, dfa, dfb):
    """cable_brackets._first_root: (status, θ, K, k): status 0 no level on the piece, 1 too many (halve), 2 a root."""
    if up:
        lo_v, hi_v = fa, fb
    else:
        lo_v, hi_v = fb, fa
    k_lo = math.ceil((lo_v - level0) / _TWO_PI)
    k_hi = math.floor((hi_v - level0) / _TWO_PI)
    last_nyq = b == math.pi and nyq > 0.0
    count = 0
    first = 0
    n = k_hi - k_lo + 1
    for j in range(n):
        k = k_lo + j if up else k_hi - j
        if k != skip and not (last_nyq and abs(level0 + _TWO_PI * k - fb) < 1e-6):
            if count == 0:
                first = k
            count += 1
            if count > 2:
                break
    if count == 0:
        return 0, 0.0, 0.0, 0
    if count > 2 and b - a > 1e-6 * b:
        return 1, 0.0, 0.0, 0
    level = level0 + _TWO_PI * first
    x0 = a + (level - fa) / (fb - fa) * (b - a) if fb != fa else 0.5 * (a + b)
    if dfa * dfb > 0.0 and (dfa > 0.0) == up:
        x1 = a + (level - fa) / dfa
        x2 = b - (fb - level) / dfb
        # the median of the three (sorted(...)[1])
        lo3, hi3 = (x1, x0) if x1 < x0 else (x0, x1)
        if x2 < lo3:
            x0 = lo3
        elif x2 < hi3:
            x0 = x2
        else:
            x0 = hi3
    lo_c = a + 1e-3 * (b - a)
    if lo_c > x0:
        x0 = lo_c
    hi_c = b - 1e-3 * (b - a)
    if hi_c < x0:
        x0 = hi_c
    root = _newton(fr, fc, modal, nums, beta, cslope, level, a, b, fa, fb, x0, up)
    r = _r_at(modal, nums, root)
    return 2, root, (r if damper else _k_of(beta, root, r)), first


# ---------------------------------------------------------------------------------------------------- the pieces

@kernel
def _ferr(fr, dist):
    """cable_brackets._ferr: Σ ferr/dist over the factors near the unit circle."""
    e = 0.0
    for i in range(fr.shape[0]):
        if fr[i, R_FERR] > 0.0:
            e += fr[i, R_FERR] / dist[i]
    return e


@kernel
def _too_near(fr, fc, t, dist, sin):
    """A crossover at θ = t too ill-conditioned by the factors near the unit circle (cable_brackets' last check)."""
    _dist_sin(fr, fc, t, dist, sin)
    return _ferr(fr, dist) > MAX_NEAR_ERROR


@kernel
def _grown(x):
    """``x`` copied into an array twice as long."""
    out = np.empty(2 * x.shape[0], dtype=x.dtype)
    out[:x.shape[0]] = x
    return out


@kernel
def min_crossing(fr, fc, modal, nums, splits, beta, theta_lo, damper):
    """cable_brackets.cable_min_crossing, compiled: (status, θ, α, pieces), status 0 not resolved (the caller
    scans), 1 no K > 0 crossover, 2 the crossover (θ, α) of least α.  ``damper``: the damper-only loop (β = 0)."""
    if damper:
        beta = 0.0
    cslope = 0.5 if damper else 0.0
    level0 = math.pi if damper else 0.5 * math.pi
    d = nums[N_D]
    nf = fr.shape[0]
    inv_pi = _inv_response(modal, d, math.pi)
    if damper:
        nyq = (-inv_pi / (-_expm1j(-math.pi))).real
    else:
        nyq = (-inv_pi + beta * _expm1j(-math.pi)).real
    best = nyq if nyq > 0.0 else math.inf
    # the stack of pieces and the roots found, grown by doubling (most calls need a few dozen)
    cap = 64 + splits.shape[0]
    st_a = np.empty(cap)
    st_b = np.empty(cap)
    st_above = np.zeros(cap, dtype=np.bool_)
    st_skip = np.empty(cap, dtype=np.int64)
    fcap = 32
    fd_t = np.empty(fcap)
    fd_v = np.empty(fcap)
    fd_a = np.empty(fcap)
    fd_b = np.empty(fcap)
    fd_lev = np.empty(fcap)
    fd_up = np.zeros(fcap, dtype=np.bool_)
    nfound = 0
    cuts = np.empty(splits.shape[0] + 2)
    cuts[0] = theta_lo
    nc = 1
    for x in splits:
        if theta_lo < x < math.pi:
            cuts[nc] = x
            nc += 1
    cuts[nc] = math.pi
    nc += 1
    top = 0
    for i in range(nc - 2, -1, -1):
        st_a[top], st_b[top], st_above[top], st_skip[top] = cuts[i], cuts[i + 1], False, _NOSKIP
        top += 1
    da = np.empty(nf)
    db = np.empty(nf)
    sa = np.empty(nf)
    sb = np.empty(nf)
    ranges = np.empty((nf, 2))
    pieces = 0
    log_beta = math.log(beta) if beta > 0.0 else -math.inf
    near = nums[N_NEAR] > 0.0
    while top > 0:
        if top + 3 > st_a.shape[0]:
            st_a, st_b, st_skip = _grown(st_a), _grown(st_b), _grown(st_skip)
            st_above = _grown(st_above)
        top -= 1
        a, b, above, skip = st_a[top], st_b[top], st_above[top], st_skip[top]
        pieces += 1
        if pieces > MAX_PIECES or not (b - a > 4.0 * _EPS * b):
            return 0, 0.0, 0.0, pieces
        _dist_sin(fr, fc, a, da, sa)
        _dist_sin(fr, fc, b, db, sb)
        rmin, rmax = _bounds_r(fr, nums, a, b, da, db, ranges)
        if above:
            if beta > rmin:
                rmin = beta
        if rmax <= beta:
            continue
        lower = rmin if damper else _k_of(beta, a, rmin)
        if lower * (1.0 - 1e-9) > best:
            continue
        if beta > 0.0 and not (rmin > beta or above):
            dl_lo, dl_hi = _dlogr_bounds(fr, a, b, sa, sb, ranges)
            if dl_lo > 0.0 or dl_hi < 0.0:
                up = dl_lo > 0.0
                ra = math.log(_base(fr, fc, modal, nums, a)[3])
                rb = math.log(_base(fr, fc, modal, nums, b)[3])
                if near:
                    if abs(ra - log_beta) <= _ferr(fr, da) or abs(rb - log_beta) <= _ferr(fr, db):
                        return 0, 0.0, 0.0, pieces
                if up:
                    low_end, high_end = ra, rb
                else:
                    low_end, high_end = rb, ra
                if high_end <= log_beta:
                    continue
                if low_end >= log_beta:
                    st_a[top], st_b[top], st_above[top], st_skip[top] = a, b, True, skip
                    top += 1
                    pieces -= 1
                    continue
                frac = (log_beta - ra) / (rb - ra)
                x0 = a * (b / a) ** frac if b > 2.0 * a else a + frac * (b - a)
                if up:
                    ts = _solve_log_r(fr, fc, modal, nums, False, log_beta, a, b, x0)
                else:
                    ts = _solve_log_r(fr, fc, modal, nums, True, -log_beta, a, b, x0)
                if not a < ts < b:
                    return 0, 0.0, 0.0, pieces
                if up:
                    st_a[top], st_b[top] = ts, b
                else:
                    st_a[top], st_b[top] = a, ts
                st_above[top], st_skip[top] = True, skip
                top += 1
                pieces -= 1
                continue
        elif beta == 0.0 or rmin > beta or above:
            dlo, dhi = _bounds_d(fr, nums, beta, a, b, sa, sb, rmin, rmax, ranges, cslope)
            pa = _base(fr, fc, modal, nums, a)
            fa, dfa, _ra = _assemble(beta, cslope, a, pa[0], pa[1], pa[2], pa[3])
            pb = _base(fr, fc, modal, nums, b)
            fb, dfb, _rb = _assemble(beta, cslope, b, pb[0], pb[1], pb[2], pb[3])
            e = 0.0
            if near:
                e_a = _ferr(fr, da)
                e_b = _ferr(fr, db)
                e = e_a
                if e_b > e:
                    e = e_b
                n_a = math.floor((fa - level0) / _TWO_PI + 0.5)
                n_b = math.floor((fb - level0) / _TWO_PI + 0.5)
                if (abs(fa - (level0 + _TWO_PI * n_a)) <= e_a and n_a != skip) or \
                        (abs(fb - (level0 + _TWO_PI * n_b)) <= e_b and b != math.pi):
                    return 0, 0.0, 0.0, pieces
            if dlo > 0.0 or dhi < 0.0:
                status, t, v, k = _first_root(fr, fc, modal, nums, beta, damper, cslope, level0, a, b, fa, fb,
                                              dlo > 0.0, nyq, skip, dfa, dfb)
                if status == 0:
                    continue
                if status == 2:
                    if v > 0.0:
                        if nfound == fd_t.shape[0]:
                            fd_t, fd_v, fd_a, fd_b, fd_lev = _grown(fd_t), _grown(fd_v), _grown(fd_a), _grown(fd_b), \
                                _grown(fd_lev)
                            fd_up = _grown(fd_up)
                        fd_t[nfound], fd_v[nfound], fd_a[nfound], fd_b[nfound] = t, v, a, b
                        fd_lev[nfound], fd_up[nfound] = level0 + _TWO_PI * k, dlo > 0.0
                        nfound += 1
                        if v < best:
                            best = v
                    if t >= b:
                        continue
                    st_a[top], st_b[top], st_above[top], st_skip[top] = t, b, above, k
                    top += 1
                    continue
            f_min, f_max = _range(fa, fb, dlo, dhi, b - a)
            if near:
                f_min, f_max = f_min - e, f_max + e
            if level0 + _TWO_PI * math.ceil((f_min - level0) / _TWO_PI) > f_max:
                continue
        mid = math.sqrt(a * b) if b > 1000.0 * a else 0.5 * (a + b)
        st_a[top], st_b[top], st_above[top], st_skip[top] = mid, b, above, skip
        top += 1
        st_a[top], st_b[top], st_above[top], st_skip[top] = a, mid, above, skip
        top += 1
    have = False
    bt = bv = 0.0
    if nyq > 0.0:
        have, bt, bv = True, math.pi, nyq
        if near and _too_near(fr, fc, math.pi, da, sa):
            return 0, 0.0, 0.0, pieces
    for j in range(nfound):
        if fd_v[j] <= best * (1.0 + 1e-6):
            ok, t, v = _polish(fr, fc, modal, nums, beta, damper, fd_t[j], fd_a[j], fd_b[j], fd_lev[j], fd_up[j])
            if not ok:
                return 0, 0.0, 0.0, pieces
            if v > 0.0 and not (nyq > 0.0 and math.pi - t <= 1e-9):
                if near and _too_near(fr, fc, t, da, sa):
                    return 0, 0.0, 0.0, pieces
                if not have or v < bv or (v == bv and t < bt):
                    have, bt, bv = True, t, v
        elif near:
            # a root left unpolished as above the least: unless beside a near factor its value may be that much low
            _dist_sin(fr, fc, fd_t[j], da, sa)
            e = _ferr(fr, da)
            if e > MAX_NEAR_ERROR and fd_v[j] * (1.0 - e) <= best * (1.0 + 1e-6):
                return 0, 0.0, 0.0, pieces
    if not have:
        return 1, 0.0, 0.0, pieces
    return 2, bt, bv, pieces


@kernel
def batch_rows(fr_all, fc_all, modal_all, nums_all, splits_all, f_off, s_off, loop, betas, lo_b, lo_k, same):
    """min_crossing on every row (optim.stability.cable_batch): the damper-only loop from lo_b, then the K loop at
    betas from lo_k; (status, θ, value) of each, as min_crossing's.  Row i's factored loop is loop[i]'s (its factors
    fr/fc between f_off[loop[i]] and f_off[loop[i] + 1], its modal form and splits likewise: one per sampled plant,
    shared by the rows of its delays and dampings); its numbers (s, arg L, |L|, d, near) are nums_all[i], the row's own
    (the whole delay d moves s and d alone).  ``same[i]`` < i: row i's loop and numbers are row same[i]'s (one plant at
    several B), whose damper-only loop's answer it takes."""
    n = betas.shape[0]
    st_b = np.zeros(n, dtype=np.int64)
    st_k = np.zeros(n, dtype=np.int64)
    th_b = np.zeros(n)
    al_b = np.zeros(n)
    th_k = np.zeros(n)
    al_k = np.zeros(n)
    for i in range(n):
        g = loop[i]
        fr = fr_all[f_off[g]:f_off[g + 1]]
        fc = fc_all[f_off[g]:f_off[g + 1]]
        splits = splits_all[s_off[g]:s_off[g + 1]]
        modal = modal_all[g]
        nums = nums_all[i]
        j = same[i]
        if j < i:
            s, t, v = st_b[j], th_b[j], al_b[j]
        else:
            s, t, v, _p = min_crossing(fr, fc, modal, nums, splits, 0.0, lo_b[i], True)
        st_b[i], th_b[i], al_b[i] = s, t, v
        if s == 2 and betas[i] >= v:
            continue                       # β ≥ β_max: no K loop to solve
        s, t, v, _p = min_crossing(fr, fc, modal, nums, splits, betas[i], lo_k[i], False)
        st_k[i], th_k[i], al_k[i] = s, t, v
    return st_b, th_b, al_b, st_k, th_k, al_k


def cable_min_crossing_compiled(loop: CableLoop, beta: float, theta_lo: float, damper: bool = False
                                ) -> tuple[tuple[float, float] | None, int] | None:
    """cable_brackets.cable_min_crossing's answer, by the kernel (the same bits)."""
    fr, fc, modal, nums, splits = loop.arrays
    status, t, v, pieces = min_crossing(fr, fc, modal, nums, splits, float(beta), float(theta_lo), bool(damper))
    if status == 0:
        return None
    return (None if status == 1 else (t, v)), pieces


def compile_kernels() -> None:
    """Compile the kernel now (or load it from numba's cache) on the LHifAM cable, K loop and damper loop."""
    from models.device import Device
    from models.plants import stiffness_loop_plant
    from optim.stability.cable_loop import cable_loop

    loop = cable_loop(stiffness_loop_plant(Device(preset="lhifam", delay=0.005)))
    if loop is not None:
        for beta, damper in ((0.0, False), (1e-3, False), (0.0, True)):
            cable_min_crossing_compiled(loop, beta, 1e-6, damper)
        fr, fc, modal, nums, splits = loop.arrays
        off = np.array([0, fr.shape[0]], dtype=np.int64)
        batch_rows(fr, fc, modal[None, :], nums[None, :], splits, off, np.array([0, splits.shape[0]], dtype=np.int64),
                   np.zeros(1, dtype=np.int64), np.array([1e-3]), np.array([1e-6]), np.array([1e-6]),
                   np.zeros(1, dtype=np.int64))
