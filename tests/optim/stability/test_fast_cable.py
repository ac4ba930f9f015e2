"""The cable's bounded scan (optim.stability.fast_cable) held against the scan of every crossover.

2,000 random cable devices: δ from 1e-10 to 1, cable modes from 10 rad/s to 0.9·Nyquist, cable damping from 0
to large, undamped cables (every damping 0, only B > 0 or nothing) included, whole and fractional delays up to
200 samples, B = 0, B uniform in [0, B_max) and B within 1e-4 of B_max.  K_cr and its frequency agree to 1e-12
relative, widened near B_max by K_cr's own conditioning there (K_cr ∝ B_max − B: a rounding of θ moves it by
~ε·B/(B_max − B)), exactly as tests/optim/stability/test_fast_rigid.py does for the rigid path.  Both paths
share the grid and its brackets; they differ in which brackets they solve and how (Newton on Im H against
Illinois), so this holds the bound that skips brackets and the solver.
"""

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability import margins
from optim.stability.fast_cable import modal_bound
from optim.stability.margins import critical_stiffness, loop_plant, max_stable_damping, scan_critical_stiffness
from optim.stability.reference import reference_critical_stiffness
from tests.optim.stability.random_cables import random_cable


@pytest.fixture(autouse=True)
def _double_paths_only(monkeypatch):
    """These tests hold the double paths (brackets, bounded scan) to the double scan; the 40-digit re-solve of a cable's
    K_cr near B_max (optim.stability.near_b_max) is held to the closed loop in test_near_b_max_band.py."""
    monkeypatch.setattr(margins, "RHO_REFINE", math.inf)

RTOL = 1e-12


def _cable(rng: np.random.Generator, i: int) -> Device:
    # cable damping 0–10 N·s/m over five decades; every fortieth cable undamped (every damping 0)
    return random_cable(rng, i, short_top=8, cable_damping="absolute", undamped=lambda j: j % 40 == 7)


def _agree(dev: Device, fast, scan, b_max: float | None):
    assert fast.path in ("fast", "bounded-scan", "scan") and scan.path == "scan"
    kf, ks = fast.critical_stiffness, scan.critical_stiffness
    if math.isinf(ks) or ks == 0.0:
        assert kf == ks, (kf, ks)
        return
    tol = RTOL
    if b_max is not None and math.isfinite(b_max) and fast.damping > 0:
        # K = Re H is a difference of O(β sin(θ/2)) terms near B_max: its rounding, relative to K
        theta = scan.crossover_frequency * dev.sample_time
        cancel = 2 * fast.damping / dev.damping_scale * math.sin(theta / 2) * dev.stiffness_scale / ks
        tol = RTOL + 64 * np.finfo(float).eps * max(cancel, fast.damping / max(b_max - fast.damping, 1e-300))
    if abs(kf / ks - 1) <= tol:
        return
    # beyond that (tiny δ within 1e-3 of B_max: both are ~1e-10 off): no worse than the scan against the
    # 40-digit reference rung
    ref = reference_critical_stiffness(dev, fast.damping).critical_stiffness
    ef, es = abs(kf / ref - 1), abs(ks / ref - 1)
    assert ef <= max(2 * es, RTOL), (kf, ks, ref, ef, es)


@pytest.mark.slow
def test_bounded_scan_matches_scan_on_random_cables(monkeypatch):
    # the cable brackets (optim.stability.cable_brackets) answer first now: turned off here, so that this holds
    # their fallback, the bounded scan, on every device (tests/optim/stability/test_cable_brackets.py holds them)
    monkeypatch.setattr(margins, "cable_min_crossing", lambda *args, **kwargs: None)
    rng = np.random.default_rng(20)
    n, bounded = 2000, 0
    for i in range(n):
        dev = _cable(rng, i)
        kind = i % 3
        if kind == 0:
            b, bm = 0.0, None
        else:
            bm = max_stable_damping(dev)
            if not math.isfinite(bm):
                b, bm = 0.0, None
            else:
                b = bm * (rng.uniform(0, 1) if kind == 1 else 1 - 10 ** rng.uniform(-4, -1))
        if dev.damping + b <= 0.0:
            continue
        fast = critical_stiffness(dev, b, b_max=bm)
        scan = scan_critical_stiffness(dev, b, b_max=bm)
        bounded += fast.path == "bounded-scan"
        _agree(dev, fast, scan, bm)
        if fast.crossover_frequency is not None and scan.crossover_frequency is not None:
            assert abs(fast.crossover_frequency / scan.crossover_frequency - 1) <= 1e-9
    assert bounded >= 0.9 * n * 0.97


def test_bound_is_below_h_on_random_arcs():
    """The bound of |H| on an arc is below |H| sampled densely on it (the bound a skipped bracket rests on)."""
    rng = np.random.default_rng(3)
    for i in range(60):
        dev = _cable(rng, i)
        plant = loop_plant(dev)
        modal = plant.modal_form()
        if modal is None:
            continue
        beta = float(rng.uniform(0, 1)) * (dev.delta + 1e-3)
        a = np.sort(rng.uniform(1e-4, math.pi, 40))
        b = np.minimum(a + 10 ** rng.uniform(-6, -1, 40), math.pi)
        lb = modal_bound(modal, beta, a, b)
        for lo, hi, bound in zip(a, b, lb):
            t = np.linspace(lo, hi, 201)
            h = -plant.inverse_response(t) + beta * np.expm1(-1j * t)
            assert bound <= np.abs(h).min() * (1 + 1e-9), (dev, lo, hi, bound, np.abs(h).min())


def test_lazy_crossover_list_is_the_scans():
    dev = Device(preset="lhifam", delay=0.05)
    fast, scan = critical_stiffness(dev), scan_critical_stiffness(dev)
    assert fast.path == "fast"          # the cable brackets (optim.stability.cable_brackets)
    # the scan's list, its binding entry the brackets' (the same crossover, to the last ulps)
    assert len(fast.crossovers) == len(scan.crossovers)
    for a, b in zip(fast.crossovers, scan.crossovers):
        assert a.frequency == pytest.approx(b.frequency, rel=1e-12)
        assert a.stiffness == pytest.approx(b.stiffness, rel=1e-12)
    assert min(c.stiffness for c in fast.crossovers) == fast.critical_stiffness
