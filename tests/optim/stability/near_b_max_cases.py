"""Cables within 1e-3 of B_max, both sides (issue 34): the exact rung's K_cr held to its own error estimate, and
every K_cr = 0 answer's stable set (no K, or a band) held to the closed loop, by methods that share no code with
zwidth's: tests/optim/independent.py (physical coordinates, its own ZOH, numpy eigenvalues; mpmath eigenvalues in
50 digits where the double cannot resolve the pole's side).

One harness for the slow test (test_near_b_max_band.py) and bench/bench_near_b_max.py (the full run written into
docs/properties_analysis.md)."""

from __future__ import annotations

import math
import time

import numpy as np

from optim.stability.analysis import analyse_stability
from optim.stability.margins import max_stable_damping
from optim.stability.stable_band import crossings_at
from tests.optim.independent import radius_excess_mp, spectral_radius
from tests.optim.stability.random_cables import random_cable

#: the double independent radius decides a side only this far from 1; closer, 50-digit mpmath eigenvalues
DOUBLE_MARGIN = 1e-9
#: delays of the run, in samples (the mpmath eigenvalues grow with the shift register)
TOP_DELAY = 16


def _excess(dev, k: float, b: float) -> float:
    """max |z| − 1 of the wall (K, B) by the independent closed loop (double, else 50-digit mpmath)."""
    t, m = dev.sample_time, dev.mass
    r = spectral_radius(dev, k * t * t / m, b * t / m) - 1.0
    if abs(r) > DOUBLE_MARGIN:
        return r
    return float(radius_excess_mp(dev, k, b))


def one_case(seed: int, i: int) -> dict:
    """The i-th case of ``seed``: a random cable, B = B_max·(1 ∓ gap), gap log-uniform in [1e-9, 1e-3]."""
    rng = np.random.default_rng([seed, i])
    dev = random_cable(rng, i, top=TOP_DELAY)
    b_max = max_stable_damping(dev)
    gap = 10 ** rng.uniform(-9, -3)
    above = bool(i % 2)
    out = {"i": i, "above": above, "gap": gap, "device": dev.model_dump(exclude_none=True)}
    if not math.isfinite(b_max) or b_max <= 0:
        return {**out, "kind": "skipped", "why": "no finite B_max"}
    b = b_max * (1.0 + gap if above else 1.0 - gap)
    out["damping"] = b
    t0 = time.perf_counter()
    a = analyse_stability(dev, None, b)
    out["ms"] = (time.perf_counter() - t0) * 1e3
    k, est = a.critical_stiffness, a.error_estimate
    if not above:
        out["kind"] = "below"
        if k is None or k == 0.0:
            # K_cr = 0 below B_max (B_max's own rounding at gaps ~1e-9): held to the closed loop at a small K
            small = 1e-6 * (dev.damping + b) / (dev.sample_time / 2 + dev.delay)
            out.update(k=k, est=est, ok=k == 0.0 and _excess(dev, small, b) > 0.0, checked="K_cr = 0 at a small K")
            return out
        out.update(k=k, est=est)
        if not (est is not None and math.isfinite(est) and est < 0.5):
            out.update(ok=None, checked="no bound claimed")
            return out
        lo, hi = _excess(dev, k * (1.0 - est), b), _excess(dev, k * (1.0 + est), b)
        out.update(ok=lo < 0.0 < hi, lo=lo, hi=hi, checked="stable at K(1 − est), unstable at K(1 + est)")
        return out
    out["kind"] = "above"
    out["k"] = k
    if k != 0.0:
        return {**out, "ok": False, "checked": "K_cr > 0 above B_max"}
    band = a.stable_band
    out["band"] = band
    beta = b * dev.sample_time / dev.mass
    ks = sorted({c[0] * dev.stiffness_scale for c in crossings_at(dev, beta)})
    if band is not None:
        lo_k, hi_k = band
        mid = math.sqrt(lo_k * hi_k) if math.isfinite(hi_k) else 2.0 * lo_k
        checks = [_excess(dev, mid, b) < 0.0, _excess(dev, lo_k * (1 - 1e-6), b) > 0.0]
        if math.isfinite(hi_k):
            checks.append(_excess(dev, hi_k * (1 + 1e-6), b) > 0.0)
        out.update(ok=all(checks), checked="band: stable inside, unstable just outside each edge")
        return out
    if "undetermined" in (a.reason or ""):
        out.update(ok=None, checked="undetermined (said)")
        return out
    # "no positive stiffness is stable": unstable below, between and above every crossover (at most 40 intervals
    # checked: past that the band analysis counts only those its crossing directions leave nearly stable)
    tests = ([0.5 * ks[0]] if ks else [1e-6]) + [math.sqrt(x * y) for x, y in zip(ks, ks[1:])][:40] + \
        ([2.0 * ks[-1]] if ks else [])
    out.update(ok=all(_excess(dev, kk, b) > 0.0 for kk in tests), intervals=len(tests),
               checked="no stable K: unstable in every interval between crossovers")
    return out


def run(seed: int, cases: int, start: int = 0) -> list[dict]:
    return [one_case(seed, i) for i in range(start, start + cases)]
