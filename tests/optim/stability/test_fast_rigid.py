"""The fast exact path (optim.stability.fast_rigid, optim.stability.fast_batch) held against the scan of every crossover.

The scan is today's exact path (optim.stability.crossovers' grid, bisection of every interval where arg H turns,
near-tangency search, Illinois to 4 ulp), run here vectorised through optim.robust.batch's own scan on
the same devices.  10,000+ random rigid devices: δ from 1e-10 to 3, whole and fractional delays up to
200 samples, B = 0, B uniform in [0, B_max) and B within 1e-4 of B_max (0.9999·B_max).

Tolerance: 1e-12 relative, widened near B_max by K_cr's own conditioning there (K_cr ∝ B_max − B, so a
rounding of B or of θ moves it by ~ε·B/(B_max − B); both methods are ~1e-12 from the 40-digit
reference at B = 0.9999·B_max, tests/optim/stability/test_margins.py holds the scan to it).
"""

import numpy as np
import pytest

from models.device import Device
from models.plants import stiffness_loop_plant
from optim.robust.batch import _Evaluator, _grids, _Loop, _min_crossing
from optim.stability.fast_batch import fast_rigid_batch
from optim.stability.fast_rigid import fast_rigid
from optim.stability.margins import critical_stiffness, max_stable_damping, scan_critical_stiffness
from optim.stability.reference import reference_critical_stiffness

RTOL = 1e-12


def _devices(n: int, seed: int, long_delays: bool) -> list[Device]:
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        delta = 10 ** rng.uniform(-10, 0.5)
        if long_delays:
            ds = float(rng.choice([20, 50, 200])) if i % 2 else float(rng.uniform(5, 200))
        else:
            ds = float(rng.integers(0, 6)) if i % 2 else float(rng.uniform(0, 8))
        t = float(rng.choice([5e-4, 1e-3, 2e-3]))
        m = 10 ** rng.uniform(-3, 1)
        out.append(Device(mass=m, damping=delta * m / t, sample_time=t, delay=ds * t))
    return out


def _scan(devices, plants, betas=None):
    """(α_cr, θ) of the K loop at ``betas`` or (β_max, θ_b) of the damper loop: optim.robust.batch's scan."""
    with np.errstate(all="ignore"):
        ev = _Evaluator(plants)
        grid = _grids(devices, plants, np.zeros(len(devices)) if betas is None else betas)
        inv = ev.inverse(grid)
        e = np.expm1(-1j * grid)
        if betas is None:
            return _min_crossing(_Loop(ev, None), grid, -inv / (-e))
        return _min_crossing(_Loop(ev, betas), grid, -inv + betas[:, None] * e)


def _check(devices, seed):
    rng = np.random.default_rng(seed + 1)
    n = len(devices)
    plants = [stiffness_loop_plant(d) for d in devices]
    beta_max, _ = _scan(devices, plants)
    kind = np.arange(n) % 3
    frac = np.where(kind == 1, rng.uniform(0, 1, n), 1 - 10 ** rng.uniform(-4, -1, n))
    betas = np.where(kind == 0, 0.0, frac * beta_max)
    alpha, theta = _scan(devices, plants, betas)
    with np.errstate(all="ignore"):
        fast = fast_rigid_batch(np.array([d.delta for d in devices]), np.array([d.delay_samples for d in devices]),
                                betas)
    ok = fast.ok
    assert ok.mean() > 0.99, f"{(~ok).sum()} of {n} fell back to the scan"
    np.testing.assert_allclose(fast.beta_max[ok], beta_max[ok], rtol=RTOL, atol=0)
    cond = np.where(betas > 0, betas / (beta_max - betas), 0.0)
    tol = RTOL + 4 * np.finfo(float).eps * cond
    err = np.abs(fast.alpha[ok] / alpha[ok] - 1)
    worst = int(np.argmax(err / tol[ok]))
    assert np.all(err <= tol[ok]), (devices[np.nonzero(ok)[0][worst]], betas[ok][worst], err[worst])
    # the same crossover (not another with the same K): θ to 1e-9
    np.testing.assert_allclose(fast.theta[ok], theta[ok], rtol=1e-9)
    return ok


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_fast_path_agrees_with_the_scan_on_10000_devices(seed):
    """4 × 2,500 devices with up to 8 samples of delay (the long delays below: the scan's grid grows with d)."""
    _check(_devices(2500, seed, long_delays=False), seed)


@pytest.mark.slow
def test_fast_path_agrees_with_the_scan_at_long_delays():
    _check(_devices(120, 7, long_delays=True), 7)


def test_scalar_path_equals_batch_path_and_is_used():
    """The public critical_stiffness (scalar fast path) against the batch fast path and the scan, one by one."""
    devices = _devices(150, 11, long_delays=False) + _devices(30, 12, long_delays=True)
    rng = np.random.default_rng(5)
    paths = []
    for i, dev in enumerate(devices):
        b = 0.0 if i % 3 == 0 else max_stable_damping(dev) * (rng.uniform(0, 1) if i % 3 == 1 else 1.05)
        got = critical_stiffness(dev, b)
        ref = scan_critical_stiffness(dev, b)
        paths.append(got.path)
        if ref.critical_stiffness == 0.0:
            assert got.critical_stiffness == 0.0 and got.reason == ref.reason
            continue
        assert got.critical_stiffness == pytest.approx(ref.critical_stiffness, rel=RTOL)
        assert got.crossover_frequency == pytest.approx(ref.crossover_frequency, rel=1e-9)
        if b > 0:
            assert got.max_stable_damping == pytest.approx(ref.max_stable_damping, rel=RTOL)
        if i % 3 == 0:    # the lazily found crossover list (rising-phase roots + the tail's scan) = the scan's
            assert min(c.stiffness for c in got.crossovers) == got.critical_stiffness
            assert len(got.crossovers) == len(ref.crossovers)
            for a, c in zip(got.crossovers, ref.crossovers):
                assert a.frequency == pytest.approx(c.frequency, rel=1e-9)
                assert a.stiffness == pytest.approx(c.stiffness, rel=RTOL)
    assert paths.count("fast") >= 0.97 * len(paths)


@pytest.mark.slow
@pytest.mark.parametrize("kw, b_frac", [
    ({"mass": 1.0, "damping": 1e-6, "delay": 0.0}, 0.0),            # δ = 1e-9, d = 0: θ ≈ 4e-5
    ({"mass": 5.4, "damping": 3.5, "delay": 0.0}, 0.5),             # d = 0: B_max and K_cr at Nyquist
    ({"mass": 1.0, "damping": 1e-3, "delay": 0.05}, 0.9999),        # 0.9999·B_max, d = 50
    ({"mass": 1.0, "damping": 0.5, "delay": 0.0037}, 0.3),          # fractional delay 3.7
    ({"mass": 1.05e-3, "damping": 0.0085, "delay": 0.05}, 0.0),
])
def test_against_the_40_digit_reference(kw, b_frac):
    dev = Device(**kw)
    b = b_frac * max_stable_damping(dev)
    fast = fast_rigid(stiffness_loop_plant(dev), b / dev.damping_scale)
    assert fast is not None
    ref = reference_critical_stiffness(dev, b).critical_stiffness
    tol = 1e-12 + 4e-16 * b_frac / (1 - b_frac)
    assert fast.alpha * dev.stiffness_scale == pytest.approx(ref, rel=tol)


def test_result_pickles_with_its_crossover_list():
    """Compute workers send results pickled: the lazily found list travels as a list, equal to the scan's."""
    import pickle

    dev = Device(mass=5.4, damping=3.5, delay=0.005)
    res = critical_stiffness(dev, 20.0)
    back = pickle.loads(pickle.dumps(res))
    assert back == res and back.path == "fast"
    assert back.crossovers == res.crossovers
    assert [c.frequency for c in back.crossovers] == pytest.approx(
        [c.frequency for c in scan_critical_stiffness(dev, 20.0).crossovers], rel=1e-9)


def test_fallback_is_said():
    """Cable devices say they took the bounded scan, the scan itself says so; a rigid one says it was not scanned."""
    assert critical_stiffness(Device(preset="lhifam")).path == "fast"     # the cable brackets
    assert scan_critical_stiffness(Device(preset="lhifam")).path == "scan"
    assert critical_stiffness(Device(preset="lhifam", cable=None)).path == "fast"
    assert scan_critical_stiffness(Device(preset="lhifam", cable=None)).path == "scan"
