"""An independent sup of the delayed passivity bound, for the property tests: numpy scan + mpmath refinement.

P(θ) = (K·T/2)·s_d(θ) − B·cos((d+1)θ) is written here in the form P = A(θ)·sin u − C·cos u, A = (K·T/2)·cot(θ/2),
C = K·T/2 + B, u = (d+1)θ (not the Dirichlet quotient optim.stability.passivity samples), on a grid of its own:
96 points per period of u, offset by half a step from θ = 0.  Every sampled local maximum is polished in floats
(Newton on P' with the form's own derivatives, inside ±1 sample); those within ``window`` (relative to P's scale)
of the best, at most MAX_REFINED of them, and the first FIRST_LOBES peaks (P ≤ E(θ), which falls with θ: in a flat
bound the highest lobes are the first) are refined in mpmath (``DPS`` digits: Newton on P' from the float polish,
kept inside ±2 samples, whose ends are candidates too); θ = 0 (the limit (K·T/2)(2d+1) − B) and θ = π are taken in mpmath too.  Shares no code with optim.stability.passivity or optim.verification.
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np

DPS = 32
#: candidates refined at most (a flat bound, hk ≪ B, has d nearly equal lobes: the highest by the parabola)
MAX_REFINED = 24
#: the first peaks (smallest θ) always refined
FIRST_LOBES = 4


def _p_mp(hk: mp.mpf, b: mp.mpf, d: int, x: mp.mpf) -> mp.mpf:
    if x == 0:
        return hk * (2 * d + 1) - b
    u = (d + 1) * x
    return hk * mp.cot(x / 2) * mp.sin(u) - (hk + b) * mp.cos(u)


def _slopes_mp(hk: mp.mpf, b: mp.mpf, d: int, x: mp.mpf) -> tuple[mp.mpf, mp.mpf]:
    """(P', P'') of the form A·sin u − C·cos u."""
    e = d + 1
    cu, su = mp.cos_sin((d + 1) * x)
    ch, sh = mp.cos_sin(x / 2)
    a0, a1, a2 = hk * ch / sh, -hk / (2 * sh * sh), hk * ch / (2 * sh ** 3)
    c = hk + b
    return (a1 * su + a0 * e * cu + c * e * su,
            a2 * su + 2 * a1 * e * cu - a0 * e * e * su + c * e * e * cu)


def mp_sup(hk: float, b: float, d: int, window: float = 1e-9) -> tuple[float, float, int]:
    """(sup P as a float, rounded from ``DPS`` digits; its θ; candidates refined)."""
    e = d + 1
    m = 96 * e + 64
    h = math.pi / m
    theta = (np.arange(m) + 0.5) * h
    u = e * theta
    vals = hk / np.tan(theta / 2) * np.sin(u) - (hk + b) * np.cos(u)
    padded = np.concatenate([[-np.inf], vals, [-np.inf]])
    peaks = np.flatnonzero((vals >= padded[:-2]) & (vals > padded[2:]))
    x = theta[peaks].copy()
    c = hk + b
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(5):
            sh, ch = np.sin(x / 2), np.cos(x / 2)
            a0 = hk * ch / sh
            a1 = -hk / (2 * sh * sh)
            a2 = hk * ch / (2 * sh ** 3)
            su, cu = np.sin(e * x), np.cos(e * x)
            f1 = a1 * su + a0 * e * cu + c * e * su
            f2 = a2 * su + 2 * a1 * e * cu - a0 * e * e * su + c * e * e * cu
            step = np.where(f2 < 0, -f1 / f2, 0.0)
            x = np.clip(x + np.nan_to_num(step), theta[peaks] - h, theta[peaks] + h)
        x = np.clip(x, h / 4, math.pi)
        x_polished = np.full(m, np.nan)
        x_polished[peaks] = x
        est = np.maximum(hk / np.tan(x / 2) * np.sin(e * x) - c * np.cos(e * x), vals[peaks])
    scale = abs(hk) * (2 * d + 1) + abs(b)
    order = np.argsort(-est)
    keep = order[est[order] >= est[order[0]] - window * scale][:MAX_REFINED] if peaks.size else order
    keep = np.union1d(keep, np.arange(min(FIRST_LOBES, peaks.size)))
    with mp.workdps(DPS):
        mhk, mb = mp.mpf(hk), mp.mpf(b)
        best_v, best_t = _p_mp(mhk, mb, d, mp.mpf(0)), mp.mpf(0)
        v_pi = _p_mp(mhk, mb, d, +mp.pi)
        if v_pi > best_v:
            best_v, best_t = v_pi, +mp.pi
        for j in peaks[keep]:
            a = mp.mpf(max(float(theta[j]) - 2 * h, h / 4))
            c = mp.mpf(min(float(theta[j]) + 2 * h, math.pi))
            x = mp.mpf(float(x_polished[j]))       # Newton on P' from the float polish, kept inside [a, c]
            cands = [x]
            for _ in range(4):
                f1, f2 = _slopes_mp(mhk, mb, d, x)
                if not f2 < 0:
                    cands += [a, c, mp.mpf(float(theta[j]))]   # not a concave peak: its bracket's ends and sample
                    break
                x = min(max(x - f1 / f2, a), c)
                if abs(f1 / f2) < mp.mpf(10) ** (-DPS + 6) * (1 + abs(x)):
                    break
            cands.append(x)
            for x in cands:
                if 0 <= x <= mp.pi:
                    v = _p_mp(mhk, mb, d, x)
                    if v > best_v:
                        best_v, best_t = v, x
        return float(best_v), float(best_t), int(len(keep))
