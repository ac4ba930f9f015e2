"""Velocity filters with V(π) = 0 (order-2 Butterworth, moving averages of even length): θ = π is a pole of h_B and
h_M, not a crossing (optim.stability.rendered_rigid.v_zero_at_pi, rendered.real_crossings(pole_at_pi=True)).

Checked against independent methods: the exact zero against mpmath's R(−1) and a closed form; the factored V_n
against mpmath at 50 digits; the listed crossings' absence at π on both paths; the B_max and mass-range answers on
walls the property run (bench/bench_pi_zero_properties.py) found cut short before the fix, against closed-loop
eigenvalues (optim/stability/closed_loop_rendered.py, written from the filter's specification)."""

from __future__ import annotations

import math
import warnings

import mpmath as mp
import numpy as np
import pytest

from models.device import Device
from models.velocity_filter import BackwardDifference, LowPass, MovingAverage, TransferFunctionFilter, rendering
from optim.stability import rendered as R
from optim.stability.closed_loop import sampled_plant
from optim.stability.margins import loop_plant
from optim.stability.rendered_rigid import (
    LOOP_B,
    LOOP_K,
    LOOP_M,
    cable_real_crossings,
    rigid_real_crossings,
    v_zero_at_pi,
)
from optim.verification import check_point
from tests.optim.stability.random_cables import random_cable

T = 1e-3


def _mp_r_at_minus_one(r) -> mp.mpf:
    with mp.workdps(60):
        return mp.fsum(mp.mpf(c) * (-1) ** k for k, c in enumerate(r))


@pytest.mark.parametrize("spec, zero", [
    (MovingAverage(kind="moving_average", samples=2), True),
    (MovingAverage(kind="moving_average", samples=10), True),
    (MovingAverage(kind="moving_average", samples=20), True),
    (MovingAverage(kind="moving_average", samples=3), False),
    (MovingAverage(kind="moving_average", samples=19), False),
    (LowPass(kind="low_pass", cutoff_hz=1.0, order=2), True),
    (LowPass(kind="low_pass", cutoff_hz=449.0, order=2), True),
    (LowPass(kind="low_pass", cutoff_hz=30.0, order=1), False),
    (BackwardDifference(), False),
    # R = (1 + w)·(0.5, 0.5)/… : V = (1 − w²)(1 + w)/(4T) has R(−1) = 0 exactly
    (TransferFunctionFilter(kind="transfer_function", numerator=[250.0, 250.0, -250.0, -250.0]), True),
    (TransferFunctionFilter(kind="transfer_function", numerator=[600.0, -200.0, -400.0]), False),
])
def test_v_zero_at_pi_is_exact(spec, zero):
    vel = rendering(spec, 0.0, T).velocity
    assert v_zero_at_pi(vel) is zero
    assert (_mp_r_at_minus_one(vel.r) == 0) is zero        # the same question in 60 digits


def test_every_butterworth_cutoff_has_its_zero_at_pi():
    """The bilinear transform maps the analog low-pass's two zeros at s = ∞ to z = −1: scipy's b is b₀(1, 2, 1)."""
    for f_t in np.geomspace(1e-6, 0.4999, 300):
        assert v_zero_at_pi(rendering(LowPass(kind="low_pass", cutoff_hz=float(f_t / T), order=2), 0.0,
                                      T).velocity)


def _mp_v(vel, theta: float) -> complex:
    with mp.workdps(50):
        w = mp.exp(-1j * mp.mpf(theta))
        r = mp.fsum(mp.mpf(c) * w ** k for k, c in enumerate(vel.r))
        d = mp.fsum(mp.mpf(c) * w ** k for k, c in enumerate(vel.d))
        return complex((1 - w) * r / d)


@pytest.mark.parametrize("spec", [LowPass(kind="low_pass", cutoff_hz=3.0, order=2),
                                  LowPass(kind="low_pass", cutoff_hz=400.0, order=2),
                                  MovingAverage(kind="moving_average", samples=8)])
def test_velocity_response_is_accurate_next_to_its_zero_at_pi(spec):
    vel = rendering(spec, 0.0, T).velocity
    thetas = np.array([math.pi - 10.0 ** -k for k in range(1, 13)] + [2.0, 0.3])
    got = R.velocity_response(vel, thetas)
    horner = vel.response(thetas)
    worst_horner = 0.0
    for t, g, hv in zip(thetas, got, horner):
        ref = _mp_v(vel, float(t))
        assert abs(g - ref) <= 1e-13 * abs(ref), (t, g, ref)
        worst_horner = max(worst_horner, abs(hv - ref) / abs(ref))
    at_pi = R.velocity_response(vel, np.array([math.pi]))[0]           # V at the float π: |1 + w| ≈ 1.2e-16
    assert abs(at_pi - _mp_v(vel, math.pi)) <= 1e-13 * abs(_mp_v(vel, math.pi))
    if spec.kind == "low_pass":
        assert worst_horner > 1e-6          # what the factored form is for (a double zero: Horner's R is rounding)


def test_velocity_response_is_bit_for_bit_where_v_has_no_zero_on_the_circle():
    """(A moving average of any length has zeros on the circle: tests/optim/stability/test_circle_zeros.py.)"""
    thetas = np.linspace(1e-6, math.pi, 1001)
    for spec in (LowPass(kind="low_pass", cutoff_hz=30.0, order=1), BackwardDifference(),
                 TransferFunctionFilter(kind="transfer_function", numerator=[600.0, -200.0, -400.0])):
        vel = rendering(spec, 0.0, T).velocity
        assert np.array_equal(R.velocity_response(vel, thetas), vel.response(thetas))


def _scan(dev, r, loop, alpha, beta, mu):
    h = (R.k_loop(dev, r, beta, mu), R._b_loop(dev, r, mu), R._m_loop(dev, r, alpha, beta))[loop]
    pole = loop != LOOP_K and v_zero_at_pi(r.velocity)
    poles = R.loop_poles(r.velocity) if loop != LOOP_K else ()
    return [(c.angle, c.value, c.outward) for c in R.real_crossings(h, R._grid(dev, r, beta), pole, poles)]


def test_pi_is_not_a_crossing_of_h_b_or_h_m_on_either_path():
    """Rigid and damped cable devices with Butterworth and even averages: neither the certified path nor the scan
    lists θ = π for h_B, h_M (a pole), both list the same crossings; h_K keeps its Nyquist crossing."""
    rng = np.random.default_rng(77)
    specs = [lambda t: LowPass(kind="low_pass", cutoff_hz=0.04 / t, order=2),
             lambda t: MovingAverage(kind="moving_average", samples=4),
             lambda t: LowPass(kind="low_pass", cutoff_hz=0.3 / t, order=2),
             lambda t: MovingAverage(kind="moving_average", samples=12)]
    compared = 0
    for i in range(12):
        dev = (Device(mass=float(10 ** rng.uniform(-0.5, 1)), damping=float(10 ** rng.uniform(-1, 2)),
                      delay=float(rng.integers(0, 4)) * T)
               if i % 2 else random_cable(rng, i, low=0, top=6, short_top=3))
        r = rendering(specs[i % 4](dev.sample_time), dev.mass * float(rng.uniform(-0.8, 0.8)), dev.sample_time)
        mu, beta = r.mass / dev.mass, float(10 ** rng.uniform(-3, -1))
        plant = loop_plant(dev)
        fast_of = rigid_real_crossings if dev.cable is None else cable_real_crossings
        for loop, a, b, m in ((LOOP_B, 0.0, 0.0, mu), (LOOP_M, 0.0, beta, 0.0), (LOOP_M, 1e-4, beta, mu)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                scan = _scan(dev, r, loop, a, b, m)
                fast = fast_of(plant, r, loop, a, b, m)
            assert all(c[0] < math.pi for c in scan), (i, loop, scan)
            if fast is None:
                continue
            compared += 1
            assert all(c[0] < math.pi for c in fast), (i, loop, fast)
            # an average's zeros at 2πk/n < π are poles too (tests/optim/stability/test_circle_zeros.py): with V by
            # Horner a value ~1e5 next to one agreed to 1.2e-8 only (wall 1: 4 samples, π/2) and the scan listed the
            # pole's own sample (wall 7: 12 samples, π/3); both now take c(1 − wⁿ): every crossing compared
            assert len(fast) == len(scan), (i, loop, fast, scan)
            for (tf, vf, of), (ts, vs, os_) in zip(fast, scan):
                assert tf == pytest.approx(ts, rel=1e-9)
                assert of == os_
                assert vf == pytest.approx(vs, rel=1e-9, abs=1e-12)
    assert compared >= 18, compared


@pytest.mark.parametrize("device, samples, mass, stiffness, damping, before", [
    (dict(mass=0.44572194581077285, damping=148.86032537802024, sample_time=0.002809877212136642, delay=0.0),
     16, 0.2910432371846918, 10778.115724004532, 620.7826001578718, 5.286285285484489),
    (dict(mass=8.054201501766503, damping=600.9195316092072, sample_time=0.007167156249600866,
          delay=0.011473691548400996), 16, -6.0576496261424735, 768.1182186105174, 1417.1552739438625,
     27.661393063560674),
])
def test_mass_range_is_not_cut_short_at_pi(device, samples, mass, stiffness, damping, before):
    """Two rigid walls of the property run (bench/bench_pi_zero_properties.py, seed 31) whose mass range ended at
    h_M's rounding value at π before the fix (``before``, stable on both sides by the closed loop): each end now is
    stable just inside and unstable just outside (closed-loop eigenvalues, else the argument principle)."""
    dev = Device(**device)
    spec = MovingAverage(kind="moving_average", samples=samples)
    r = rendering(spec, mass, dev.sample_time)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        got = R.rendered_mass_range(dev, stiffness, damping, r)
    assert got is not None and got.min < mass < got.max
    assert got.min < before < got.max
    plant = sampled_plant(dev)
    alpha, beta = stiffness / dev.stiffness_scale, damping / dev.damping_scale
    for end in (got.min, got.max, before):
        gap = end - mass
        inside = check_point(dev, plant, alpha, beta, (spec, end - 1e-6 * gap)).stable
        outside = check_point(dev, plant, alpha, beta, (spec, end + 1e-6 * gap)).stable
        assert (inside, outside) == ((True, True) if end == before else (True, False)), end


def test_a_transfer_function_with_its_zero_at_pi_answers_as_the_average_it_writes_out():
    """V = (1 − z⁻²)/(2T) given as a transfer function (R = (½, ½): its zero on the circle sends h_B, h_M to the
    scan) and as the 2-sample moving average (the certified path): the same B_max and mass range, two algorithms.
    Before the fix the scan listed h_B(π) = 4800.01 (V's rounding, 1.2e-16j, over X) as a crossing."""
    dev = Device(mass=1.0, damping=5.0, delay=2e-3)
    k, b = 2000.0, 3.0
    answers = []
    for spec in (TransferFunctionFilter(kind="transfer_function", numerator=[0.5 / T, 0.0, -0.5 / T]),
                 MovingAverage(kind="moving_average", samples=2)):
        r = rendering(spec, 0.3, T)
        assert v_zero_at_pi(r.velocity)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            assert all(c.angle < math.pi for c in R._damper_crossings(dev, r, r.mass / dev.mass))
            answers.append((R.rendered_max_stable_damping(dev, r), R.rendered_mass_range(dev, k, b, r)))
        R.clear_caches()
    (b1, m1), (b2, m2) = answers
    assert m1 is not None and m2 is not None
    assert b1 == pytest.approx(b2, rel=1e-9) and math.isfinite(b1)
    assert (m1.min, m1.max) == pytest.approx((m2.min, m2.max), rel=1e-9)
