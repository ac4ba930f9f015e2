"""Random rendered walls for the filter property run (tests/optim/stability/test_filter_properties.py, a small copy;
bench/bench_filter_properties.py, the full run into docs/properties_filter.md): every kind of velocity filter,
rigid and cable devices, whole and fractional delays, virtual masses of either sign; each exact K_cr checked by
``verify`` (closed-loop eigenvalues with the filter's states at K_cr·(1 ∓ 1e-6), which share no code with the scan)."""

from __future__ import annotations

import math
import time
from collections import Counter

import numpy as np

from models.device import Device
from models.errors import InputError
from models.velocity_filter import (
    BackwardDifference,
    LowPass,
    MovingAverage,
    TransferFunctionFilter,
    rendering,
)
from optim.stability.analysis import analyse_stability
from optim.stability.rendered import rendered_max_stable_damping
from optim.verification import verify_analysis

KINDS = ("backward_difference", "low_pass_1", "low_pass_2", "moving_average", "transfer_function")


def random_device(rng: np.random.Generator) -> Device:
    """Rigid or cable; δ = bT/m log-uniform in [1e-7, 1] (one in twenty rigid devices frictionless); delays 0, 1–5
    whole samples, 0–20 or 0–120 samples (whole or fractional); T 0.1–10 ms."""
    t = 10 ** rng.uniform(-4, -2)
    m = 10 ** rng.uniform(-1, 1.5)
    delta = 10 ** rng.uniform(-7, 0)
    d = [0.0, float(rng.integers(1, 6)), rng.uniform(0, 20), rng.uniform(0, 120)][int(rng.integers(0, 4))]
    if rng.random() < 0.3:
        d = float(round(d))
    kw = dict(sample_time=t, delay=d * t)
    b = delta * m / t
    if rng.random() < 0.5:
        return Device(mass=m, damping=0.0 if rng.random() < 0.05 else b, **kw)
    mr = m * rng.uniform(0.05, 0.5)
    wn = min(10 ** rng.uniform(1, 4), 0.9 * math.pi / t)
    kc = wn ** 2 * mr * (m - mr) / m
    br = b * rng.uniform(0, 1)
    bc = rng.uniform(0, 1) * 10 ** rng.uniform(-3, 1)
    return Device(cable=dict(motor_mass=mr, body_mass=m - mr, motor_damping=br, body_damping=b - br, stiffness=kc,
                             damping=bc), **kw)


def random_filter(rng: np.random.Generator, kind: str, t: float):
    """A filter of ``kind``: cutoffs f·T log-uniform in [1e-3, 0.45]; averages of 2–20 samples; transfer functions
    a first-order low-pass by backward differences (Brown's) or a random stable second-order estimator."""
    cutoff = float(10 ** rng.uniform(-3, math.log10(0.45)) / t)
    if kind == "backward_difference":
        return BackwardDifference()
    if kind in ("low_pass_1", "low_pass_2"):
        return LowPass(kind="low_pass", cutoff_hz=cutoff, order=1 if kind == "low_pass_1" else 2)
    if kind == "moving_average":
        return MovingAverage(kind="moving_average", samples=int(rng.integers(2, 21)))
    if rng.random() < 0.5:
        tau = t * 10 ** rng.uniform(-1, 2)
        a = tau / (tau + t)
        return TransferFunctionFilter(kind="transfer_function", numerator=[(1 - a) / t, -(1 - a) / t],
                                      denominator=[1.0, -a])
    # D with a complex pair inside the circle, R random: N = (1 − w)·R/T scaled to V'(1)·T = 1
    rad, ang = rng.uniform(0.0, 0.95), rng.uniform(0, math.pi)
    den = np.array([1.0, -2 * rad * math.cos(ang), rad * rad])
    r = rng.uniform(0.1, 1.0, size=int(rng.integers(1, 4)))
    r *= den.sum() / r.sum()
    num = np.convolve([1.0, -1.0], r) / t
    return TransferFunctionFilter(kind="transfer_function", numerator=[float(c) for c in num],
                                  denominator=[float(c) for c in den])


def run_filter_property(cases: int, seed: int) -> dict:
    """Draw ``cases`` rendered walls, analyse each on the exact rung and verify it."""
    rng = np.random.default_rng(seed)
    out = {"cases": 0, "confirmed": 0, "not_checkable": [], "contradicted": [], "refused": [], "ms": [],
           "verify_ms": [], "kinds": Counter(), "confirmed_kinds": Counter(), "confirmed_positive": 0, "k_zero": 0, "k_inf": 0, "negative_mass": 0, "cable": 0,
           "fractional": 0}
    for i in range(cases):
        dev = random_device(rng)
        kind = KINDS[i % len(KINDS)]
        spec = random_filter(rng, kind, dev.sample_time)
        mass = 0.0 if (kind != "backward_difference" and rng.random() < 0.25) else dev.mass * rng.uniform(-0.9, 1.0)
        try:
            r = rendering(spec, mass, dev.sample_time)
            b_max = rendered_max_stable_damping(dev, r)
            top = b_max if math.isfinite(b_max) and b_max > 0 else 10 * max(dev.damping, 1e-3)
            damping = 0.0 if rng.random() < 0.3 else float(rng.uniform(0, 1.05 * top))
            res = analyse_stability(dev, None, damping, "exact", rendering=r)
        except InputError as exc:
            out["refused"].append(f"{kind}: {exc.field}: {exc.rule}")
            continue
        t0 = time.perf_counter()
        v = verify_analysis(dev, res, (spec, mass))
        out["verify_ms"].append((time.perf_counter() - t0) * 1e3)
        out["cases"] += 1
        out["ms"].append(res.elapsed_ms)
        out["kinds"][kind] += 1
        out["k_zero"] += res.critical_stiffness == 0.0
        out["k_inf"] += res.critical_stiffness is None
        out["negative_mass"] += mass < 0
        out["cable"] += dev.cable is not None
        out["fractional"] += dev.delay_samples != round(dev.delay_samples)
        case = (f"{kind} {spec!r} M={mass!r} B={damping!r} device={dev.model_dump(exclude_none=True)!r} "
                f"K_cr={res.critical_stiffness!r}")
        if v.verdict == "confirmed":
            out["confirmed"] += 1
            out["confirmed_kinds"][kind] += 1
            out["confirmed_positive"] += bool(res.critical_stiffness)
        elif v.verdict == "contradicted":
            out["contradicted"].append(f"{case}: {v.reason}")
        else:
            out["not_checkable"].append(f"{kind}: {v.reason}")
    return out
