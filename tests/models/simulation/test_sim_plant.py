"""The simulator's physical-unit ZOH matrices agree with models/discretize (dimensionless, independent code)."""

import numpy as np
import pytest

from models.device import Device
from models.plants import stiffness_loop_plant
from models.simulation.scene import Effects
from models.simulation.sim_plant import build_plant, sample_plant


def _response(sp, theta):
    """G(e^{jθ}) of the sampled plant from command to motor position [m/N]."""
    z = np.exp(1j * theta)
    n = sp.phi.shape[0]
    out = []
    for zk in z:
        x = np.linalg.solve(zk * np.eye(n) - sp.phi, sp.gamma0 + sp.gamma1 / zk)
        out.append(x[sp.plant.motor_position] * zk ** (-sp.d))
    return np.array(out)


@pytest.mark.parametrize("preset,cable,delay", [
    ("lhifam", False, 0.0), ("lhifam", False, 0.0014), ("lhifam", True, 0.0),
    ("lhifam", True, 0.0031), ("lhifam-reduced-pretension", True, 0.00025), ("phantom-1.0", True, 0.002)])
def test_physical_matrices_match_dimensionless_discretisation(preset, cable, delay):
    dev = Device(preset=preset, delay=delay)
    if not cable:
        dev = dev.rigid()
    eff = Effects(cable_mode={} if cable else None)
    sp = sample_plant(build_plant(dev, eff), dev.sample_time, dev.delay)
    theta = np.linspace(0.01, np.pi, 37)
    ours = _response(sp, theta) * dev.stiffness_scale          # G_n = G·m/T²
    ref = stiffness_loop_plant(dev).response(theta)
    # both are exact ZOH; they differ only by rounding in two different expm set-ups
    np.testing.assert_allclose(ours, ref, rtol=1e-8, atol=0)


def test_rigid_matrices_closed_form():
    """Φ of 1/(ms² + bs) in closed form: [[1, (1-p)m/b], [0, p]], p = e^{-bT/m}."""
    dev = Device(mass=5.4, damping=3.5)
    sp = sample_plant(build_plant(dev, Effects()), dev.sample_time, 0.0)
    p = np.exp(-3.5 * 1e-3 / 5.4)
    np.testing.assert_allclose(sp.phi, [[1, (1 - p) * 5.4 / 3.5], [0, p]], rtol=1e-13, atol=1e-18)
