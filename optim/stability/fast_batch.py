"""optim.stability.fast_rigid over many rigid devices at once, in numpy arrays (no per-point loop on the hot path).

The same equations and brackets as the scalar path, each Newton iteration one set of array operations
over the devices still iterating: a device's iterates depend only on its own numbers, so its answer does
not depend on which other devices share the batch (a study's rows are bit-identical in any chunk).  Rows
whose bounds do not close come back with ``ok`` False; the caller scans them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.discretize import rigid_coefficients, split_delay_array
from optim.stability.fast_rigid import MIN_ZERO_GAP

__all__ = ["FastBatch", "fast_rigid_batch"]

_EPS = np.finfo(float).eps
_HALF_PI = 0.5 * math.pi


@dataclass(frozen=True)
class FastBatch:
    """Dimensionless answers per device; entries with ``ok`` False are to be scanned."""

    ok: np.ndarray
    alpha: np.ndarray
    """α_cr (0 at or above β_max, inf never: a rigid loop always has a crossover)."""
    theta: np.ndarray
    """θ of the binding crossover (nan when α_cr = 0)."""
    beta_max: np.ndarray


class _Loops:
    """optim.stability.fast_rigid.rigid_loop of every device at once (arrays; ``ok`` False where it would be None)."""

    def __init__(self, delta: np.ndarray, d: np.ndarray, f: np.ndarray):
        (self.omp, self.phi12, self.g0p, self.g0v, self.g1p, self.g1v, _, self.a0, self.c0) = \
            rigid_coefficients(delta, f)
        self.d, self.whole = d.astype(float), f == 0.0
        p = self.p = 1.0 - self.omp
        with np.errstate(all="ignore"):
            # whole-sample delay: N = a(z + q), 1 − q = −c/a (from the series: exact down to δ = 0)
            o_w = -self.c0 / self.a0
            # fractional: z·N = A z² + B z + C, zeros −q: the larger from the formula, the smaller as C/(A q)
            aa, bb = self.g0p, self.g1p - p * self.g0p + self.phi12 * self.g0v
            cc = self.phi12 * self.g1v - p * self.g1p
            disc = bb * bb - 4.0 * aa * cc
            big = (bb + np.sqrt(disc)) / (2.0 * aa)
            small = cc / (aa * big)
        w = self.whole
        self.lead = np.where(w, self.a0, aa)
        self.q1, self.o1 = np.where(w, 1.0 - o_w, big), np.where(w, o_w, 1.0 - big)
        self.q2, self.o2 = np.where(w, 0.5, small), np.where(w, 0.5, 1.0 - small)
        self.w2 = np.where(w, 0.0, 1.0)
        m = np.where(w, 0.0, 1.0)
        ok = np.where(w, self.a0 > 0.0, (aa > 0.0) & (bb > 0.0) & (cc > 0.0) & (disc >= 0.0))
        ok &= (self.q1 > 0.0) & (w | ((self.q2 > 0.0) & (np.abs(self.o1) >= MIN_ZERO_GAP)
                                      & (np.abs(self.o2) >= MIN_ZERO_GAP)))
        self.slope = self.d + m + 0.5
        # the rising-phase bound of optim.stability.fast_rigid.rigid_loop: the inside zero closest to −1 exactly
        # (q1 ≥ q2, so it is q1 when q1 is inside), any other inside one at 1/(1 − q), outside ones at 1/(1 + q)
        in1, in2 = self.q1 < 1.0, (self.q2 < 1.0) & ~w
        with np.errstate(all="ignore"):
            bound = (self.slope + 1.0 / (1.0 + p) - np.where(self.q1 > 1.0, 1.0 / (1.0 + self.q1), 0.0)
                     - np.where(~w & (self.q2 > 1.0), 1.0 / (1.0 + self.q2), 0.0)
                     - np.where(in1 & in2, 1.0 / self.o2, 0.0))
            qj, oj = np.where(in1, self.q1, self.q2), np.where(in1, self.o1, self.o2)
            any_in = in1 | in2
            zero_at_minus_one = (self.o1 == 0.0) | (~w & (self.o2 == 0.0))
            self.tr, ok_r = _rising_end(bound, any_in, qj, oj, zero_at_minus_one)
            self.trb, ok_rb = _rising_end(bound + 0.5, any_in, qj, oj, zero_at_minus_one)
            ok &= ok_r & ok_rb
        n_in = in1.astype(np.int64) + in2.astype(np.int64)
        self.half = 2 * (d.astype(np.int64) + m.astype(np.int64) + 1 - n_in) + 1
        self.ok = ok & np.isfinite(self.tr) & np.isfinite(self.trb)
        for name in ("q1", "o1", "q2", "o2", "lead"):      # harmless numbers where the row is not ok
            setattr(self, name, np.where(self.ok, getattr(self, name), 0.5))
        self.lead = np.where(self.ok, self.lead, 1.0)

    def h(self, t: np.ndarray, i: np.ndarray, beta: np.ndarray) -> np.ndarray:
        """H(θ) = −1/G_n + β(e^{−jθ} − 1) as RigidZOH.inverse_response and the scan compute it."""
        z = np.exp(1j * t)
        zm1 = np.expm1(1j * t)
        zinv = 1.0 / z
        omp = self.omp[i]
        frac = (self.g0p[i] + self.g1p[i] * zinv) * (zm1 + omp) + self.phi12[i] * (self.g0v[i] + self.g1v[i] * zinv)
        num = np.where(self.whole[i], self.a0[i] * (z + 1.0) + self.c0[i], frac)
        inv = zm1 * (zm1 + omp) * np.exp(1j * self.d[i] * t) / num
        return -inv + beta * np.expm1(-1j * t)

    def parts(self, t: np.ndarray, i: np.ndarray):
        """(ψ, φ', R, R'/R) of devices i at θ = t (as optim.stability.fast_rigid._parts)."""
        sh, ch = np.sin(0.5 * t), np.cos(0.5 * t)
        st = 2.0 * sh * ch
        omp, p = self.omp[i], self.p[i]
        re_p = omp - 2.0 * sh * sh
        den_p = re_p * re_p + st * st
        psi = self.slope[i] * t - np.arctan2(re_p, st)
        dphi = self.slope[i] + (omp + 2.0 * p * sh * sh) / den_p
        dlr = p * st / den_p
        mag = np.sqrt(den_p) / self.lead[i]
        for q, o, w in ((self.q1[i], self.o1[i], None), (self.q2[i], self.o2[i], self.w2[i])):
            re_q = 2.0 * ch * ch - o
            den_q = re_q * re_q + st * st
            if w is None:
                psi = psi - np.arctan2(st, re_q)
                dphi = dphi - (o + 2.0 * q * ch * ch) / den_q
                dlr = dlr + q * st / den_q
                mag = mag / np.sqrt(den_q)
            else:
                two = w > 0
                psi = np.where(two, psi - np.arctan2(st, re_q), psi)
                dphi = np.where(two, dphi - (o + 2.0 * q * ch * ch) / den_q, dphi)
                dlr = np.where(two, dlr + q * st / den_q, dlr)
                mag = np.where(two, mag / np.sqrt(den_q), mag)
        return psi, dphi, mag, dlr

    def damper_eq(self, t, i):
        """ψ + θ/2 − π/2 (0 at a damper-loop crossover) and its derivative."""
        psi, dphi, _, _ = self.parts(t, i)
        return psi + 0.5 * t - _HALF_PI, dphi + 0.5

    def k_eq(self, t, i, beta):
        psi, dphi, r, dlr = self.parts(t, i)
        b = beta[i]
        g = b * np.cos(0.5 * t) / r
        sat = g >= 1.0
        gs = np.where(sat, 0.0, g)
        dg = gs * (-0.5 * np.tan(0.5 * t) - dlr)
        f = np.where(sat, psi - _HALF_PI, psi - np.arcsin(gs))
        df = np.where(sat, dphi, dphi - dg / np.sqrt((1.0 - gs) * (1.0 + gs)))
        zero = b == 0.0
        return np.where(zero, psi, f), np.where(zero, dphi, df)

    def start(self, i, damp, level, hi):
        a = self.slope[i] + 0.5
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(damp > 0, np.sqrt(damp / a), level / a)
            x = np.where((damp > 0) & (damp / x > 1.0), level / (a + 1.0 / damp), x)
        return np.minimum(x, 0.5 * hi)


def _rising_end(bound, any_in, qj, oj, zero_at_minus_one):
    """optim.stability.fast_rigid._rising_end of every row: (θ, ok)."""
    bound = bound * (1.0 - 1e-12)
    ok = ~any_in | (bound > 1.0 / (1.0 + qj))
    rhs = oj * (1.0 - bound * oj) / (qj * (2.0 * bound - 1.0))
    tr = np.where(any_in & (rhs > 0.0), 2.0 * np.arccos(np.minimum(1.0, np.sqrt(0.5 * rhs))), math.pi)
    return np.where(zero_at_minus_one, math.pi * (1.0 - 1e-9), tr), ok


def _solve(fun, i: np.ndarray, lo: np.ndarray, hi: np.ndarray, x: np.ndarray, *args) -> np.ndarray:
    """optim.stability.fast_rigid._solve (level 0) on every device i at once; a device stops when it converges."""
    lo, hi, x = lo.copy(), hi.copy(), x.copy()
    out = np.full(i.shape, np.nan)
    act = np.arange(i.size)
    for _ in range(200):
        if act.size == 0:
            break
        xl, ll, hl = x[act], lo[act], hi[act]
        bis = ~((ll < xl) & (xl < hl))
        geo = (ll > 0.0) & (hl > 8.0 * ll)
        xl = np.where(bis, np.where(geo, np.sqrt(ll * hl), 0.5 * (ll + hl)), xl)
        fx, dfx = fun(xl, i[act], *args)
        hit = fx == 0.0
        below = fx < 0.0
        ll = np.where(below, xl, ll)
        hl = np.where(below, hl, xl)
        narrow = hl - ll <= 4.0 * _EPS * hl
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dfx > 0.0, fx / dfx, np.inf)
        xn = xl - step
        small = (np.abs(step) <= 2.0 * _EPS * xl) & (ll <= xn) & (xn <= hl)   # (from one side, hl stays far)
        done = hit | narrow | small
        out[act[hit | narrow]] = xl[hit | narrow]
        fin = small & ~(hit | narrow)
        out[act[fin]] = xn[fin]
        lo[act], hi[act], x[act] = ll, hl, xn
        act = act[~done]
    if act.size:
        out[act] = x[act]
    return out


def fast_rigid_batch(delta: np.ndarray, delay_samples: np.ndarray, betas: np.ndarray) -> FastBatch:
    """α_cr(β) and β_max of every rigid device (δ, d = t_d/T, β: arrays; dimensionless), with ``ok`` False
    where the scan must decide.  β_max is found for every device (the studies report it at β = 0 too)."""
    n = len(delta)
    d, f = split_delay_array(delay_samples)
    L = _Loops(np.asarray(delta, float), d, f)
    betas = np.asarray(betas, float)
    ok = L.ok.copy()
    alpha, theta, bmax = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    # the damper-only loop: its first crossover θ_b on [0, θ_rb] (the Nyquist point when ψ + θ/2 reaches π/2
    # only there)
    at_pi = L.trb == math.pi
    with np.errstate(all="ignore"):
        fb_in = L.damper_eq(L.trb, np.arange(n))[0]
    fb = np.where(at_pi, (L.half - 1) * _HALF_PI, fb_in)
    ok &= fb >= 0.0
    nyq = at_pi & (L.half == 1)
    tb = np.where(nyq, math.pi, np.nan)
    i = np.nonzero(ok & ~nyq)[0]
    if i.size:
        a = L.slope[i] + 0.5                                   # optim.stability.fast_rigid._damper_start
        x0 = np.minimum((_HALF_PI + np.sqrt(_HALF_PI * _HALF_PI + 4.0 * a * L.omp[i])) / (2.0 * a), 0.5 * L.trb[i])
        tb[i] = _solve(L.damper_eq, i, np.zeros(i.size), L.trb[i], x0)
    j = np.nonzero(ok)[0]
    bmax[j] = L.parts(tb[j], j)[2]
    dead = ok & (betas > 0.0) & (betas >= bmax)
    alpha[dead] = 0.0
    live = ok & ~dead
    hi = np.where(betas > 0.0, np.minimum(tb, L.tr), L.tr)      # F̃ rises on [0, θ_r]
    nyq_k = live & (hi == math.pi) & (L.half == 1)
    k = np.nonzero(nyq_k)[0]
    theta[k] = math.pi
    with np.errstate(all="ignore"):
        fk_in = L.k_eq(np.where(live, hi, 1.0), np.arange(n), betas)[0]
    fk = np.where(hi == math.pi, (L.half - 1) * _HALF_PI, fk_in)
    solve = live & ~nyq_k & (fk > 0.0)
    ok &= ~(live & ~nyq_k & ~(fk > 0.0))
    i = np.nonzero(solve)[0]
    if i.size:
        theta[i] = _solve(L.k_eq, i, np.zeros(i.size), hi[i], L.start(i, L.omp[i] + betas[i], _HALF_PI, hi[i]),
                          betas)
    i = np.nonzero(ok & ~dead)[0]
    if i.size:
        b = betas[i]

        def h(t):
            return L.h(t, i, b)

        # optim.stability.fast_rigid.polish: one secant step on Im H, kept only when it is a few ulp and lowers |Im H|
        t = theta[i]
        step = 64.0 * _EPS * t
        with np.errstate(all="ignore"):
            h0 = h(t)
            f0, f1 = h0.imag, h(t + step).imag
            t1 = t - f0 * step / (f1 - f0)
            t1 = np.where(np.isfinite(t1), t1, t)
            h1 = h(t1)
            take = ((f1 != f0) & (f0 != 0.0) & (np.abs(t1 - t) <= 8.0 * _EPS * t) & (t1 < math.pi)
                    & (np.abs(h1.imag) < np.abs(f0)) & (t < math.pi))
        theta[i] = np.where(take, t1, t)
        # K = Re H at the root (optim.stability.rigid_kernel.re_h says why): H there was computed above
        alpha[i] = np.where(take, h1.real, h0.real)
    return FastBatch(ok, alpha, theta, bmax)
