"""optim.nonlinear_verification: the energy audit finds Abbott & Okamura's two modes on one device each,
and the measured cycle matches a cycle computed by hand."""

from __future__ import annotations

import math

import pytest

from models.device import Device
from optim.nonlinear_verification import energy_audit, measure_cycle

# 2b/T = 1000 N/m (binding), 2f_c/q = 4000 N/m
SAMPLING_BINDS = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5, coulomb_friction=0.02)
# 2f_c/q = 400 N/m (binding), 2b/T = 4000 N/m
QUANTISATION_BINDS = Device(mass=0.2, damping=2.0, encoder_resolution=1e-5, coulomb_friction=0.002)


def _soft(dev: Device, k: float):
    """the chatter probe: held at a force halfway between two encoder levels."""
    return energy_audit(dev, k, 0.0, k * dev.encoder_resolution * 50.5, ramp=0.2, hold=1.0, free=0.2)


def _hard(dev: Device, k: float, depth: float):
    """the instability probe: a deep push released in two samples."""
    return energy_audit(dev, k, 0.0, k * depth, ramp=0.02, hold=0.3, free=2.0)


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.9, 1.1])
def test_chatter_mode_appears_above_two_fc_over_q(factor):
    res = _soft(QUANTISATION_BINDS, factor * 400.0)
    assert res.active == (factor > 1)
    assert res.mode == ("chatter" if factor > 1 else "none")
    assert (res.net_energy > res.error_bound) == (factor > 1)
    if factor < 1:
        assert res.net_energy <= 0.0


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.9, 1.1])
def test_instability_mode_appears_above_two_b_over_t(factor):
    res = energy_audit(SAMPLING_BINDS, factor * 1000.0, 0.0, factor * 1000.0 * 0.07, ramp=0.02, hold=0.3, free=4.0)
    assert res.mode == ("instability" if factor > 1 else "none")
    assert (res.port_balance_max > res.error_bound) == (factor > 1)


def test_a_frictionless_quantised_wall_far_below_k_cr_settles():
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5)
    res = measure_cycle(dev, 200.0, 0.0, 1e-4, 6.0)   # 2m/b = 0.8 s: 7.5 decay times
    assert res.state == "settled"
    assert res.amplitude < 0.25e-5


def test_a_frictionless_wall_above_k_cr_grows():
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5)
    res = measure_cycle(dev, 1500.0, 0.0, 1e-3, 1.0)
    assert res.state == "growing"
    assert not math.isfinite(res.amplitude) or res.amplitude > 1e-3
