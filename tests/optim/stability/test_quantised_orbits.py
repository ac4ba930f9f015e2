"""optim.stability.quantised_orbits against an independent method: the count sequence of every found orbit is
fed, as the controller's input, to the plant stepped in the time domain with its ZOH matrices (models.discretize:
Φ, Γ0, Γ1, the delay as a shift register) for many periods; the periodic position it settles into (its mean
removed: the integrator's offset is free) must round back to the same counts (the search used a DFT instead)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.margins import critical_stiffness, loop_plant
from optim.stability.quantised_orbits import find_orbits


def _periodic_response(device: Device, stiffness: float, damping: float, counts: tuple[int, ...],
                       periods: int = 60) -> np.ndarray:
    """y/q over the last period of the plant driven by F̃ = −(κ·u_k + β·(u_k − u_{k−1})) (dimensionless)."""
    plant = loop_plant(device)
    phi, g0, g1, c = plant.matrices()
    t, m = device.sample_time, device.mass
    kappa, beta = stiffness * t * t / m, damping * t / m
    u = np.array(counts, dtype=float)
    n = len(u)
    f = -(kappa * u + beta * (u - np.roll(u, 1)))
    d = plant.d
    x = np.zeros(phi.shape[0])
    ys = np.zeros(n)
    for k in range(periods * n):
        ys[k % n] = float(c @ x)
        x = phi @ x + g0 * f[(k - d) % n] + g1 * f[(k - d - 1) % n]
    return ys - ys.mean()


@pytest.mark.parametrize("factor,delay", [(0.6, 0.0), (0.7, 0.002), (0.9, 0.001)])
def test_every_found_orbit_is_a_fixed_point_in_the_time_domain(factor, delay):
    dev = Device(mass=0.2, damping=4.0, encoder_resolution=1e-5, delay=delay)
    res = critical_stiffness(dev, 0.0)
    k = factor * res.critical_stiffness
    orbits = find_orbits(dev, k, 0.0, res.crossover_frequency * dev.sample_time)
    assert orbits
    for o in orbits[:4]:
        assert math.isclose(o.frequency_hz, 1 / (o.period * dev.sample_time))
        y = _periodic_response(dev, k, 0.0, o.counts)
        assert np.array_equal(np.round(y), np.array(o.counts))
        assert np.min(0.5 - np.abs(y - np.array(o.counts))) == pytest.approx(o.margin, abs=1e-6)
        assert math.isclose(0.5 * np.ptp(y) * 1e-5, o.amplitude, rel_tol=1e-6)


def test_no_encoder_no_orbits():
    dev = Device(mass=0.2, damping=0.5, coulomb_friction=0.01)
    assert find_orbits(dev, 100.0, 0.0, 0.3) == []


def test_far_below_k_cr_no_orbit_is_found():
    dev = Device(mass=0.2, damping=0.5, encoder_resolution=1e-5)
    res = critical_stiffness(dev, 0.0)
    assert find_orbits(dev, 0.2 * res.critical_stiffness, 0.0, res.crossover_frequency * dev.sample_time) == []
