"""Cables with every damping 0 past their B_max (issue 34): the analysis' K_cr = 0 answer's stable set ("no positive
stiffness is stable", or a band) held to the independent closed loop (tests/optim/independent.py: physical
coordinates, its own ZOH, numpy eigenvalues).  For bench/bench_rendered_band.py (docs/properties_analysis.md)."""

from __future__ import annotations

import math

import numpy as np

from optim.stability.analysis import analyse_stability
from optim.stability.margins import max_stable_damping
from optim.stability.stable_band import crossings_at
from tests.optim.independent import radius_excess_mp, spectral_radius
from tests.optim.stability.random_cables import random_cable

#: the independent double loop decides a side only beyond this (closer, the same loop in 50-digit mpmath)
DOUBLE_MARGIN = 1e-9


def one_case(seed: int, i: int) -> dict:
    """random_cable(..., top=12, undamped) and B past B_max: B_max·(1 + gap), gap log-uniform in [1e-6, 0.1], or,
    where B_max = 0 (B drives the mode out), B log-uniform in [1e-8, 0.1] of the damping scale."""
    rng = np.random.default_rng([seed, i])
    dev = random_cable(rng, i, top=12, undamped=lambda _: True)
    out: dict = {"i": i, "kind": "undamped", "device": dev.model_dump(exclude_none=True)}
    try:
        b_max = max_stable_damping(dev)
    except ValueError as exc:
        return {**out, "kind": "skipped", "why": str(exc)}
    b = b_max * (1 + 10 ** rng.uniform(-6, -1)) if b_max > 0 else dev.damping_scale * 10 ** rng.uniform(-8, -1)
    out["damping"] = b
    try:
        a = analyse_stability(dev, None, b)
    except ValueError as exc:
        return {**out, "kind": "refused", "why": str(exc)}
    out["k"] = a.critical_stiffness
    if a.critical_stiffness != 0.0:
        return {**out, "kind": "skipped", "why": "K_cr > 0"}
    t, m = dev.sample_time, dev.mass

    def side(k: float) -> bool | None:
        x = spectral_radius(dev, k * t * t / m, b * t / m) - 1.0
        if abs(x) <= DOUBLE_MARGIN:
            x = float(radius_excess_mp(dev, k, b))        # the same loop in 50-digit mpmath
        return None if x == 0.0 else x < 0.0

    band = a.stable_band
    out["band"] = band
    if band is not None:
        lo, hi = band
        sides = [side(math.sqrt(lo * hi) if math.isfinite(hi) else 2 * lo), side(lo * (1 - 1e-4))]
        if math.isfinite(hi):
            sides.append(side(hi * (1 + 1e-4)))
        if None in sides:
            return {**out, "ok": None, "checked": "band: within the independent loop's rounding"}
        return {**out, "ok": sides == [True] + [False] * (len(sides) - 1), "checked": "band"}
    if "undetermined" in (a.reason or ""):
        return {**out, "ok": None, "checked": "undetermined (said)"}
    ks = sorted({c[0] * dev.stiffness_scale for c in crossings_at(dev, b * t / m)})
    tests = ([0.5 * ks[0]] if ks else [1e-6]) + [math.sqrt(x * y) for x, y in zip(ks, ks[1:])][:40] + \
        ([2.0 * ks[-1]] if ks else [])
    sides = [side(k) for k in tests]
    if True in sides:
        return {**out, "ok": False, "checked": "none: stable in an interval"}
    if None in sides:
        return {**out, "ok": None, "checked": "none: an interval within the independent loop's rounding"}
    return {**out, "ok": True, "checked": "none"}


def run(seed: int, cases: int, start: int = 0) -> list[dict]:
    return [one_case(seed, i) for i in range(start, start + cases)]
