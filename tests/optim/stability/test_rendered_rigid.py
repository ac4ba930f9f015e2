"""The certified isolation of optim.stability.rendered_rigid against the adaptive scan (optim.stability.rendered's
real_crossings, a second algorithm) on random rigid walls of every filter kind: every real value of h_K, h_B and
h_M, with the poles' direction, where the certificate closes; and it closes on most walls (else the speed is lost).
The one compiled call (``_crossings``) is held bit for bit to its Python twin (tests/optim/stability/
rendered_rigid_python.py: numpy building the polynomials and bounds on every call, as it ran before), None for None."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from models.device import Device
from models.discretize import RigidZOH
from models.velocity_filter import LowPass, rendering
from optim.stability import rendered as R
from optim.stability.margins import loop_plant
from optim.stability.rendered_rigid import (
    LOOP_B,
    LOOP_K,
    LOOP_M,
    cable_real_crossings,
    rigid_real_crossings,
    v_zero_at_pi,
)
from tests.optim.stability.filter_properties import KINDS, random_filter
from tests.optim.stability.random_cables import random_cable
from tests.optim.stability.rendered_rigid_python import rigid_real_crossings_python

#: |h| above this is the scan's rendering of a pole of h on the circle (V(π) = 0), not a gain
_HUGE = 1e12


def _random_rigid(rng: np.random.Generator) -> Device:
    t = 10 ** rng.uniform(-4, -2)
    m = 10 ** rng.uniform(-1, 1.5)
    delta = 10 ** rng.uniform(-6, 0)
    d = [0.0, float(rng.integers(1, 6)), rng.uniform(0, 20)][int(rng.integers(0, 3))]
    return Device(mass=m, damping=delta * m / t, sample_time=t, delay=d * t)


def _scan(dev, r, loop, alpha, beta, mu):
    h = (R.k_loop(dev, r, beta, mu), R._b_loop(dev, r, mu), R._m_loop(dev, r, alpha, beta))[loop]
    pole = loop != LOOP_K and v_zero_at_pi(r.velocity)          # as rendered.py's callers: π is a pole of h_B, h_M
    return [(c.angle, c.value, c.outward) for c in R.real_crossings(h, R._grid(dev, r, beta), pole)]


def test_certified_crossings_match_the_scan():
    rng = np.random.default_rng(3030)
    certified = total = 0
    for i in range(150):
        dev = _random_rigid(rng)
        spec = random_filter(rng, KINDS[i % len(KINDS)], dev.sample_time)
        r = rendering(spec, dev.mass * rng.uniform(-0.9, 1.0) if rng.random() < 0.5 else 0.0, dev.sample_time)
        mu = r.mass / dev.mass
        beta = float(10 ** rng.uniform(-4, 0))
        alpha = float(10 ** rng.uniform(-6, -1))
        plant = loop_plant(dev)
        assert isinstance(plant, RigidZOH)
        for loop, a, b, m in ((LOOP_K, 0.0, beta, mu), (LOOP_B, 0.0, 0.0, mu), (LOOP_M, 0.0, beta, 0.0),
                              (LOOP_M, alpha, beta, 0.0)):
            total += 1
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                fast = rigid_real_crossings(plant, r, loop, a, b, m)
                assert fast == rigid_real_crossings_python(plant, r, loop, a, b, m), (i, loop)
                if fast is None:
                    continue
                certified += 1
                scan = [c for c in _scan(dev, r, loop, a, b, m) if abs(c[1]) < _HUGE]
            fast = [c for c in fast if abs(c[1]) < _HUGE]
            where = f"wall {i} loop {loop}: {dev!r} {spec!r} M={r.mass!r}"
            assert len(fast) == len(scan), where
            for (tf, vf, of), (ts, vs, os_) in zip(fast, scan):
                assert tf == pytest.approx(ts, rel=1e-9, abs=1e-12), where
                assert vf == pytest.approx(vs, rel=1e-8, abs=1e-12 * max(1.0, abs(vs))), where
                assert of == os_, where
    assert certified >= 0.9 * total, (certified, total)   # 594 of 600 when written


def test_k_cr_by_the_certified_path_equals_the_scan_and_is_fast():
    """The LHifAM with a 50 Hz first-order filter: the same K_cr as the scan, and the certified path is taken."""
    dev = Device(mass=5.4, damping=3.5)
    r = rendering(LowPass(kind="low_pass", cutoff_hz=50.0, order=1), 0.0, dev.sample_time)
    b = 0.5 * R.rendered_max_stable_damping(dev, r)
    beta = b / dev.damping_scale
    fast = rigid_real_crossings(loop_plant(dev), r, LOOP_K, 0.0, beta, 0.0)
    assert fast is not None
    scan = [c for c in _scan(dev, r, LOOP_K, 0.0, beta, 0.0) if c[1] > 0]
    kcr = R.rendered_critical_stiffness(dev, b, r).critical_stiffness
    assert kcr == pytest.approx(min(v for _, v, _ in scan) * dev.stiffness_scale, rel=1e-12)
    assert math.isfinite(kcr)


def test_certified_cable_crossings_match_the_scan():
    """Damped cables (tests/optim/stability/random_cables.py, delays up to 20 samples) with every filter kind: the
    certified isolation on the factored cable loop, refined on the modal form, against the scan of the numpy
    evaluation; where h is a difference of terms > 100× larger (low damping) it gives up and the scan answers."""
    rng = np.random.default_rng(3131)
    certified = total = 0
    for i in range(40):
        dev = random_cable(rng, i, low=0, top=20, short_top=4)
        spec = random_filter(rng, KINDS[i % len(KINDS)], dev.sample_time)
        r = rendering(spec, dev.mass * rng.uniform(-0.9, 1.0) if rng.random() < 0.5 else 0.0, dev.sample_time)
        mu = r.mass / dev.mass
        beta = float(10 ** rng.uniform(-4, 0))
        alpha = float(10 ** rng.uniform(-6, -1))
        plant = loop_plant(dev)
        for loop, a, b, m in ((LOOP_K, 0.0, beta, mu), (LOOP_B, 0.0, 0.0, mu), (LOOP_M, 0.0, beta, 0.0),
                              (LOOP_M, alpha, beta, 0.0)):
            total += 1
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                fast = cable_real_crossings(plant, r, loop, a, b, m)
                if fast is None:
                    continue
                certified += 1
                scan = [c for c in _scan(dev, r, loop, a, b, m) if abs(c[1]) < _HUGE]
            fast = [c for c in fast if abs(c[1]) < _HUGE]
            where = f"cable {i} loop {loop}: {dev!r} {spec!r} M={r.mass!r}"
            assert len(fast) == len(scan), where
            for (tf, vf, of), (ts, vs, os_) in zip(fast, scan):
                assert tf == pytest.approx(ts, rel=1e-9, abs=1e-12), where
                assert vf == pytest.approx(vs, rel=1e-9, abs=1e-12 * max(1.0, abs(vs))), where
                assert of == os_, where
    assert certified >= 0.4 * total, (certified, total)     # 82 of 160 when written

