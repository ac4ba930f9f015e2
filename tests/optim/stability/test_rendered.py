"""The rendered wall C(z) = K + B·V(z) + M·A(z) (optim.stability.rendered, passivity_rendered): today's wall through
the general path, Brown's closed form, and K_cr, B_max and the M-width held to closed-loop eigenvalues with the
filter's states (optim.stability.closed_loop_rendered, which shares no code with the scan)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from models.velocity_filter import (
    DEFAULT_RENDERING,
    LowPass,
    MovingAverage,
    TransferFunctionFilter,
    rendering,
)
from optim.stability.closed_loop import radius_excess, sampled_plant
from optim.stability.closed_loop_rendered import rendered_closed_loop
from optim.stability.margins import scan_critical_stiffness
from optim.stability.passivity import passivity_margin
from optim.stability.passivity_rendered import rendered_passivity
from optim.stability.rendered import (
    rendered_critical_stiffness,
    rendered_mass_range,
    rendered_max_stable_damping,
)

LHIFAM = Device(mass=5.4, damping=3.5, sample_time=1e-3)
CABLE = Device.model_validate({"cable": {"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.1,
                                         "body_damping": 3.4, "stiffness": 79500, "damping": 15}, "sample_time": 1e-3})


def _random_device(rng: np.random.Generator, i: int) -> Device:
    t = float(rng.choice([5e-4, 1e-3, 2e-3]))
    m = 10 ** rng.uniform(-1, 1)
    b = m / t * 10 ** rng.uniform(-5, -1)
    delay = t * (float(rng.integers(0, 6)) if i % 2 else rng.uniform(0, 6))
    if i % 3 == 0:
        mr = m * rng.uniform(0.05, 0.5)
        wn = min(10 ** rng.uniform(2, 3.5), 0.8 * math.pi / t)
        kc = wn ** 2 * mr * (m - mr) / m
        return Device.model_validate({"cable": {
            "motor_mass": mr, "motor_damping": b * 0.1, "body_mass": m - mr, "body_damping": b * 0.9, "stiffness": kc,
            "damping": 2 * math.sqrt(kc * mr) * rng.uniform(0.02, 0.5)}, "sample_time": t, "delay": delay})
    return Device(mass=m, damping=b, sample_time=t, delay=delay)


def _spec(rng: np.random.Generator, i: int, t: float):
    kind = i % 4
    if kind == 0:
        return LowPass(kind="low_pass", cutoff_hz=float(10 ** rng.uniform(1, math.log10(0.4 / t))), order=1)
    if kind == 1:
        return LowPass(kind="low_pass", cutoff_hz=float(10 ** rng.uniform(1, math.log10(0.4 / t))), order=2)
    if kind == 2:
        return MovingAverage(kind="moving_average", samples=int(rng.integers(2, 9)))
    tau = t * 10 ** rng.uniform(-1, 1)
    a = tau / (tau + t)
    return TransferFunctionFilter(kind="transfer_function", numerator=[(1 - a) / t, -(1 - a) / t],
                                  denominator=[1.0, -a])


def _stable(device: Device, stiffness: float, damping: float, spec, mass: float) -> bool | None:
    m, t = device.mass, device.sample_time
    q = rendered_closed_loop(sampled_plant(device), spec, t, stiffness * t * t / m, damping * t / m, mass / m)
    ex = radius_excess(q)
    return True if ex.decided_stable else False if ex.decided_unstable else None


@pytest.mark.parametrize("device", [LHIFAM, LHIFAM.model_copy(update={"delay": 0.0015}), CABLE,
                                    CABLE.model_copy(update={"delay": 0.0023})])
@pytest.mark.parametrize("damping", [0.0, 5.0])
def test_todays_wall_through_the_general_path_is_the_scan(device, damping):
    ref = scan_critical_stiffness(device, damping)
    got = rendered_critical_stiffness(device, damping, DEFAULT_RENDERING)
    assert got.critical_stiffness == pytest.approx(ref.critical_stiffness, rel=1e-13)
    assert [c.frequency for c in got.crossovers] == pytest.approx([c.frequency for c in ref.crossovers], rel=1e-12)
    if damping > 0:
        assert got.max_stable_damping == pytest.approx(ref.max_stable_damping, rel=1e-12)


def test_browns_closed_form_on_200_random_walls():
    """Brown (1995, appendix A): a first-order filter mapped by backward differences (v_f·(τ s + 1) = v with
    s → (1 − z⁻¹)/T, so a = τ/(τ + T)), no delay, B ≥ 0: passive iff b > K·T/2 + B·T/(T + 2τ)."""
    rng = np.random.default_rng(1995)
    worst = 0.0
    for i in range(200):
        t = 10 ** rng.uniform(-4, -2)
        tau = t * 10 ** rng.uniform(-1, 2)
        k = 10 ** rng.uniform(0, 5)
        b = 0.0 if i % 10 == 0 else 10 ** rng.uniform(-2, 2)
        a = tau / (tau + t)
        spec = TransferFunctionFilter(kind="transfer_function", numerator=[(1 - a) / t, -(1 - a) / t],
                                      denominator=[1.0, -a])
        dev = Device(mass=10 ** rng.uniform(-1, 1), damping=1.0, sample_time=t)
        got = rendered_passivity(dev, k, b, rendering(spec, 0.0, t)).required_damping
        worst = max(worst, abs(got / (k * t / 2 + b * t / (t + 2 * tau)) - 1))
    assert worst <= 1e-10


def test_general_passivity_is_the_delayed_form_for_todays_wall():
    rng = np.random.default_rng(7)
    for i in range(40):
        dev = Device(mass=5.4, damping=3.5, sample_time=1e-3, delay=1e-3 * float(rng.integers(0, 12)))
        k, b = 10 ** rng.uniform(2, 4), rng.uniform(0, 20)
        ref = passivity_margin(dev, k, b).required_damping
        assert rendered_passivity(dev, k, b, DEFAULT_RENDERING).required_damping == pytest.approx(ref, rel=1e-10)


def test_a_filter_costs_passivity():
    """The filter lowers the damper's high-frequency gain: with no delay B·T/(T + 2τ) < B."""
    r = rendering(LowPass(kind="low_pass", cutoff_hz=50.0), 0.0, 1e-3)
    assert rendered_passivity(LHIFAM, 3000, 10, r).required_damping < passivity_margin(LHIFAM, 3000, 10).required_damping


@pytest.mark.parametrize("seed", range(4))
def test_critical_stiffness_is_confirmed_by_the_closed_loop(seed):
    rng = np.random.default_rng(100 + seed)
    checked = 0
    for i in range(12):
        dev = _random_device(rng, i + seed)
        spec = _spec(rng, i, dev.sample_time)
        mass = dev.mass * rng.uniform(-0.5, 0.5) if i % 3 else 0.0
        damping = dev.damping * rng.uniform(0, 3)
        res = rendered_critical_stiffness(dev, damping, rendering(spec, mass, dev.sample_time))
        k = res.critical_stiffness
        if k == 0.0:
            assert _stable(dev, 1e-9 * dev.mass / dev.sample_time ** 2, damping, spec, mass) is not True
            continue
        if not math.isfinite(k):
            continue
        lo, hi = _stable(dev, k * (1 - 1e-6), damping, spec, mass), _stable(dev, k * (1 + 1e-6), damping, spec, mass)
        assert lo is not False and hi is not True, (dev, spec, mass, damping, k)
        checked += lo is True and hi is False
    assert checked >= 6


def _k0_radius(device: Device, damping: float, spec, mass: float) -> float:
    """Largest |z| − 1 of the K = 0 closed loop without its fixed pole at z = 1 (the eigenvalue q = 0 of Q)."""
    m, t = device.mass, device.sample_time
    q = np.linalg.eigvals(rendered_closed_loop(sampled_plant(device), spec, t, 0.0, damping * t / m, mass / m))
    q = np.delete(q, np.argmin(np.abs(q)))
    return float(np.max(np.abs(1.0 + q)) - 1.0)


def test_max_stable_damping_and_mass_range_are_confirmed_by_the_closed_loop():
    spec = LowPass(kind="low_pass", cutoff_hz=50.0)
    r = rendering(spec, 0.0, 1e-3)
    b_max = rendered_max_stable_damping(LHIFAM, r)
    assert _k0_radius(LHIFAM, b_max * (1 - 1e-6), spec, 0.0) < -1e-11
    assert _k0_radius(LHIFAM, b_max * (1 + 1e-6), spec, 0.0) > 1e-11
    k, b = 4000.0, 5.0
    rng = rendered_mass_range(LHIFAM, k, b, r)
    assert rng is not None and rng.min < 0.0 < rng.max
    for edge in (rng.min, rng.max):
        inside, outside = edge * (1 - 1e-6), edge * (1 + 1e-6)
        assert _stable(LHIFAM, k, b, spec, inside) is True
        assert _stable(LHIFAM, k, b, spec, outside) is False


def test_undamped_cable_is_refused_with_its_field():
    from models.errors import InputError
    dev = Device.model_validate({"cable": {"motor_mass": 0.3, "motor_damping": 0, "body_mass": 5.1,
                                           "body_damping": 0, "stiffness": 79500, "damping": 0}, "sample_time": 1e-3})
    with pytest.raises(InputError) as exc:
        rendered_critical_stiffness(dev, 1.0, rendering(LowPass(kind="low_pass", cutoff_hz=50.0), 0.0, 1e-3))
    assert exc.value.field == "velocity_filter"


def _mp_k_loop(device: Device, spec, damping: float, mass: float):
    """h_K(θ) in 40-digit mpmath: −1/G_n from the reference rung's own discretisation (optim.stability.reference),
    the filter from its coefficients R, D evaluated again in mpmath."""
    from mpmath import mp

    from models.discretize import split_delay
    from models.velocity_filter import velocity_transfer
    from optim.stability.reference import _cable_h, _rigid_h

    d, f = split_delay(device.delay_samples)
    inv = (_rigid_h(mp.mpf(device.delta), d, mp.mpf(f), 0) if device.cable is None
           else _cable_h(device, d, mp.mpf(f), 0))
    vel = velocity_transfer(spec, device.sample_time)
    beta, mu = mp.mpf(damping) * device.sample_time / device.mass, mp.mpf(mass) / device.mass

    def poly(c, w):
        return sum(mp.mpf(ck) * w ** k for k, ck in enumerate(c))

    def h(theta):
        w = 1 / mp.expj(theta)
        v = (1 - w) * poly(vel.r, w) / poly(vel.d, w)
        return inv(theta) - beta * v - mu * v * (1 - w)
    return h


@pytest.mark.slow
def test_critical_stiffness_agrees_with_40_digits():
    """The exact rung's claim (1e-12) for filtered walls: the binding crossover refined again in 40-digit mpmath on the
    reference rung's discretisation (rigid and cable, whole and fractional delay, M of either sign)."""
    from mpmath import mp

    from optim.stability.reference import _bisect
    mp.dps = 40
    cases = [(LHIFAM, LowPass(kind="low_pass", cutoff_hz=50.0), 5.0, 0.0),
             (LHIFAM.model_copy(update={"delay": 0.0037}), LowPass(kind="low_pass", cutoff_hz=80.0, order=2), 8.0,
              -1.0),
             (LHIFAM.model_copy(update={"delay": 0.002}), MovingAverage(kind="moving_average", samples=4), 3.0, 1.5),
             (CABLE, LowPass(kind="low_pass", cutoff_hz=100.0), 2.0, 0.0),
             (CABLE.model_copy(update={"delay": 0.0013}), LowPass(kind="low_pass", cutoff_hz=150.0, order=2), 1.0,
              0.0)]
    worst = 0.0
    for dev, spec, damping, mass in cases:
        res = rendered_critical_stiffness(dev, damping, rendering(spec, mass, dev.sample_time))
        theta = res.crossover_frequency * dev.sample_time
        h = _mp_k_loop(dev, spec, damping, mass)
        root = _bisect(h, mp.mpf(theta) * (1 - mp.mpf("1e-7")), min(mp.mpf(theta) * (1 + mp.mpf("1e-7")), mp.pi), 40)
        k = float(mp.re(h(root))) * dev.mass / dev.sample_time ** 2
        worst = max(worst, abs(res.critical_stiffness / k - 1))
    assert worst <= 1e-12


@pytest.mark.parametrize("mass", [-7.0, -6.0, -3.0, 2.0])
def test_a_frictionless_device_walks_the_damper_first(mass):
    """b = 0: the loop at B = 0 keeps a pole at z = 1 for every M, so B goes first; M below −m drives that pole out
    (z − 1 ≈ −β/(1 + μ)): K_cr = 0, which the closed loop confirms; above −m the answer is held to it too."""
    dev = Device(mass=5.4, damping=0.0, sample_time=1e-3, delay=0.001)
    spec = LowPass(kind="low_pass", cutoff_hz=80.0)
    res = rendered_critical_stiffness(dev, 5.0, rendering(spec, mass, 1e-3))
    k = res.critical_stiffness
    if mass < -5.4:
        assert k == 0.0
        assert _stable(dev, 1e-3, 5.0, spec, mass) is False
    else:
        assert 0 < k < math.inf
        assert _stable(dev, k * (1 - 1e-6), 5.0, spec, mass) is True
        assert _stable(dev, k * (1 + 1e-6), 5.0, spec, mass) is False
