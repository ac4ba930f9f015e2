"""The cable brackets (optim.stability.cable_brackets) held against the scan of every crossover.

10,000+ random damped cable devices (mirroring tests/optim/stability/test_fast_rigid.py): δ from 1e-10 to 1, cable
modes from 10 rad/s to 0.9·Nyquist, cable damping from tiny (1e-9 of critical) to large, whole and fractional
delays up to 20 samples (200 more up to 200 samples and 30 up to 10,000 in a second test), B = 0, B uniform in [0, B_max) and B within 1e-4
of B_max.  The reference is the scan (optim.stability.crossovers' grid, bisection wherever arg H turns, Illinois
to 4 ulp): margins.scan_critical_stiffness and the same scan of the damper-only loop.  B_max (the damper-only
loop, by the brackets too) and K_cr agree to 1e-12 relative, K_cr widened near B_max by its own conditioning
there (K_cr ∝ B_max − B: a rounding of θ moves it by ~ε·B/(B_max − B)), exactly as the rigid test does, and
by its conditioning in θ (an ulp of θ moves K by θ|∂Re H/∂θ|/K ulps: ~1e8 where a mode 1e-9 of critical damping
from the unit circle is crossed at its resonance; both sit equally far from the 40-digit reference there); the
binding crossover's frequency to 1e-9 (the same crossover, not another with the same K).  At most 3 % may fall
back to the bounded scan (``path`` says so), every undamped cable does.
"""

import math

import numpy as np
import pytest

from models.device import Device
from models.plants import stiffness_loop_plant
from optim.stability import margins
from optim.stability.cable_brackets import cable_loop, clear_memo
from optim.stability.margins import (
    _damper_crossings,
    critical_stiffness,
    loop_plant,
    max_stable_damping,
    scan_critical_stiffness,
)
from tests.optim.stability.random_cables import random_cable


@pytest.fixture(autouse=True)
def _double_paths_only(monkeypatch):
    """These tests hold the double paths (brackets, bounded scan) to the double scan; the 40-digit re-solve of a cable's
    K_cr near B_max (optim.stability.near_b_max) is held to the closed loop in test_near_b_max_band.py."""
    monkeypatch.setattr(margins, "RHO_REFINE", math.inf)

RTOL = 1e-12


def _devices(n: int, seed: int, delays: str) -> list[Device]:
    rng = np.random.default_rng(seed)
    low, top = {"short": (0, 20), "medium": (20, 200), "long": (200, 10_000)}[delays]
    # every fifth short one within 4 samples; cable damping from 1e-9 of critical (a resonance 1e-9 from the unit
    # circle) to ~10× critical
    return [random_cable(rng, i, low=low, top=top, short_top=4 if delays == "short" else None,
                         cable_damping="critical") for i in range(n)]


def _scan_b_max(dev: Device) -> tuple[float, float]:
    """(B_max, θ_b) by the scan of the damper-only loop (optim.stability.margins' own scan of it)."""
    found = _damper_crossings(dev, loop_plant(dev))
    if not found:
        return math.inf, math.nan
    best = min(found, key=lambda c: c.value)
    return best.value * dev.damping_scale, best.angle


def _sum_cond(plant, theta: float) -> float:
    """Σ|terms|/|sum| of the modal form's G_n at θ (x₁ = (Γ₁ + Σ y_i e_i)/(z − 1), G = c₁x₁ + Σ y_i c_i): every
    evaluation of G (the scan's, the brackets') is off by about ε times this, relative (≫ 1 where the integrator,
    a slow pole 1e-10 from z = 1 and modes 1e-8 from the unit circle nearly cancel, and next to a mode, where
    e^{jθ} − 1 − λ cancels)."""
    lam, c1, c2v, e12v, r0, r1, g0_1, g1_1 = plant.modal_form()
    zm1, zinv = np.expm1(1j * theta), np.exp(-1j * theta)
    y = (r0 + zinv * r1) / (zm1 - lam)
    x1 = (g0_1 + zinv * g1_1 + y @ e12v) / zm1
    g = c1 * x1 + y @ c2v
    # each y_i also carries the rounding of z − 1 − λ_i, relative (|z − 1| + |λ_i|)/|z − 1 − λ_i| (near a mode)
    ay = np.abs(y) * (1.0 + (abs(zm1) + np.abs(lam)) / np.abs(zm1 - lam))
    mag = abs(c1) * (abs(g0_1) + abs(g1_1) + ay @ np.abs(e12v)) / abs(zm1) + ay @ np.abs(c2v)
    return max(1.0, float(mag / abs(g)))


def _theta_cond(plant, beta: float | None, theta: float, alpha: float) -> float:
    """How many ulps of K the rounding of the crossover moves it (both methods sit this far from the 40-digit
    reference): θ·|∂Re H/∂θ|/K (an ulp of θ; ~1e8 where a mode 1e-9 of critical damping from the unit circle
    is crossed at its resonance), and (|1/G| + |β(e^{−jθ} − 1)|)·(1 + |∂Re H/∂θ|/|∂Im H/∂θ|)/K per relative
    rounding η of 1/G: the value and the root of Im H both move by η·their terms (large near B_max, where the
    terms cancel).  η = 16 ε·(the modal sum's own condition, _sum_cond): the brackets evaluate the modal form
    in Python numbers, the scan in numpy, each rounded that much (up to ~4e-14 apart where the sum cancels)."""
    h = 1e-7 * theta
    t = np.array([theta - h, theta + h, theta])
    inv = plant.inverse_response(t)
    # the K loop at β, or (β None) the damper-only loop, whose value at its crossover is β_max
    val = -inv / (-np.expm1(-1j * t)) if beta is None else -inv + beta * np.expm1(-1j * t)
    d_re, d_im = abs(val[1].real - val[0].real) / (2 * h), abs(val[1].imag - val[0].imag) / (2 * h)
    terms = abs(val[2]) + (abs(inv[2]) + 2 * beta * math.sin(theta / 2) if beta is not None else 0.0)
    eta = 16.0 * _sum_cond(plant, theta)
    return max(theta * d_re, eta * terms * (1.0 + (d_re / d_im if d_im > 0 else math.inf))) / alpha


def _check(devices: list[Device], seed: int) -> tuple[int, int]:
    """(devices on the fast path, devices) after holding each against the scan."""
    rng = np.random.default_rng(seed + 1)
    eps = np.finfo(float).eps
    fast = 0
    for i, dev in enumerate(devices):
        plant = loop_plant(dev)
        bs, ks, t = dev.damping_scale, dev.stiffness_scale, dev.sample_time
        b_scan, theta_b = _scan_b_max(dev)
        bm = max_stable_damping(dev)
        if math.isfinite(b_scan):
            tol_b = RTOL + 64 * eps * _theta_cond(plant, None, theta_b, b_scan / bs)
            assert abs(bm / b_scan - 1) <= tol_b, (dev, bm, b_scan)
        else:
            assert math.isinf(bm), (dev, bm)
        kind = i % 3
        frac = rng.uniform(0, 1) if kind == 1 else 1 - 10 ** rng.uniform(-4, -1)
        b = 0.0 if kind == 0 or not math.isfinite(b_scan) else frac * b_scan
        res = critical_stiffness(dev, b, b_max=bm if b > 0 else None)
        ref = scan_critical_stiffness(dev, b, b_max=b_scan if b > 0 else None)
        fast += res.path == "fast"
        assert res.path in ("fast", "bounded-scan")
        if not 0.0 < ref.critical_stiffness < math.inf:
            assert res.critical_stiffness == ref.critical_stiffness, (dev, b, res, ref)
            continue
        beta, theta, alpha = b / bs, ref.crossover_frequency * t, ref.critical_stiffness / ks
        cond = b / (b_scan - b) if b > 0 else 0.0
        # K = Re H is a difference of O(β sin(θ/2)) terms near B_max: its rounding, relative to K
        cancel = 2.0 * beta * math.sin(theta / 2) / alpha
        tol = RTOL + 64 * eps * max(cond, cancel, _theta_cond(plant, beta, theta, alpha))
        err = abs(res.critical_stiffness / ref.critical_stiffness - 1)
        assert err <= tol, (dev, b, res.critical_stiffness, ref.critical_stiffness, err, tol)
        assert abs(res.crossover_frequency / ref.crossover_frequency - 1) <= 1e-9, (dev, b, res, ref)
    return fast, len(devices)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_cable_brackets_agree_with_the_scan_on_10000_devices(seed):
    """4 × 2,500 damped cables with up to 20 samples of delay (longer ones below: the scan's grid grows with d)."""
    fast, n = _check(_devices(2500, seed, "short"), seed)
    # cable damping is drawn down to 1e-9 of critical: about a fifth of these resonances sit within
    # cable_loop.MIN_MODE_GAP (1e-8) of the unit circle; the bounded scan answers there only where the binding
    # crossover is conditioned past cable_loop.MAX_NEAR_ERROR (issue 32; before, on every one of them)
    assert fast >= 0.75 * n, f"{n - fast} of {n} fell back to the bounded scan"


@pytest.mark.slow
def test_cable_brackets_agree_with_the_scan_at_long_delays():
    """200 cables with 20 to 200 samples of delay, 30 with 200 to 10,000 (the scan: ~160,000 samples each)."""
    fast, n = _check(_devices(200, 7, "medium"), 7)
    fast_long, n_long = _check(_devices(30, 8, "long"), 8)
    # as above: resonances within MIN_MODE_GAP of the circle (about a quarter here) were all the bounded scan's
    assert fast + fast_long >= 0.7 * (n + n_long), f"{n + n_long - fast - fast_long} fell back to the bounded scan"


def test_undamped_cable_says_it_fell_back():
    """Every damping 0: the mode is on the unit circle, the brackets do not apply; the answer says which path ran."""
    dev = Device(cable=dict(motor_mass=0.3, body_mass=5.1, motor_damping=0.0, body_damping=0.0, stiffness=79500.0,
                            damping=0.0), sample_time=1e-3, delay=5e-3)
    assert cable_loop(stiffness_loop_plant(dev)) is None
    assert critical_stiffness(dev, 1.0).path != "fast"


def test_lhifam_takes_the_brackets():
    for delay in (0.0, 0.005, 0.0037, 0.2):
        dev = Device(preset="lhifam", delay=delay)
        assert critical_stiffness(dev).path == "fast"
        assert critical_stiffness(dev, 0.5 * max_stable_damping(dev)).path == "fast"


def test_the_devices_memo_changes_no_bit():
    """The brackets keep a device's β-free work (points, R's bounds on pieces) for its next call: a sweep in B with
    it warm answers, to the bit, as each B alone with it cleared (and as a repeated call)."""
    rng = np.random.default_rng(41)
    for dev in _devices(12, 41, "medium") + [Device(preset="lhifam", delay=d) for d in (0.0, 0.0037, 0.05)]:
        bm = max_stable_damping(dev)
        bs = [0.0] + ([f * bm for f in rng.uniform(0, 1, 3)] if math.isfinite(bm) else [])
        clear_memo()
        warm = [critical_stiffness(dev, b, b_max=bm if b > 0 else None) for b in bs]
        for b, w in zip(bs, warm):
            clear_memo()
            cold = critical_stiffness(dev, b, b_max=bm if b > 0 else None)
            again = critical_stiffness(dev, b, b_max=bm if b > 0 else None)
            for r in (cold, again):
                assert (r.critical_stiffness, r.crossover_frequency, r.path) == \
                    (w.critical_stiffness, w.crossover_frequency, w.path), (dev, b)
