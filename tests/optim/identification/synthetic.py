"""Synthetic lab data from the project's own scene simulator (models/simulation/sim_plant.py, models/simulation/friction.py).

The scene simulator's plant (build_plant: rigid or two-mass cable, SI units) and its exact sampled form
with the loop delay on the motor force (sample_plant) are stepped with the scene simulator's own
steppers — models.simulation.sim_loop.linear_step, or models.simulation.friction.FrictionStepper (event-located Coulomb
friction) — driven by an open-loop motor command (a scene's wall controller cannot inject a chirp or
a PRBS; POST /v1/simulate's push force acts on the body mass without the loop delay, so it cannot be the
commanded force of an identification).  The encoder then quantises and adds Gaussian noise.

This shares the physics with the identification but none of its code path: sim_plant builds its
matrices in SI units from its own expm calls, the identification uses models/plants.stiffness_loop_plant
(dimensionless RigidZOH / StateSpaceZOH in modal form).
"""

from __future__ import annotations

import numpy as np

from models.device import Device
from models.simulation.friction import FrictionStepper
from models.simulation.scene import Effects
from models.simulation.sim_loop import linear_step
from models.simulation.sim_plant import build_plant, sample_plant

__all__ = ["CABLE", "RIGID", "excitation", "simulate_experiment"]

RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
#: the LHifAM's cable block (chapter Table 2), 84 Hz mode
CABLE = {"cable": {"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.1, "body_damping": 3.4,
                   "stiffness": 79500.0, "damping": 15.0}, "sample_time": 0.001}


def excitation(n: int, sample_time: float, amplitude: float = 2.0, seed: int = 0, f1: float = 200.0,
               hold: int = 3) -> np.ndarray:
    """A log chirp 0.5 Hz → f1 plus a PRBS held ``hold`` samples, zero mean [N]."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * sample_time
    dur = n * sample_time
    f0 = 0.5
    k = np.log(f1 / f0) / dur
    chirp = np.sin(2 * np.pi * f0 * (np.exp(k * t) - 1) / k)
    prbs = np.repeat(rng.choice([-1.0, 1.0], size=n // hold + 1), hold)[:n]
    return amplitude * (0.6 * chirp + 0.4 * prbs)


def simulate_experiment(device: Device, force: np.ndarray, *, friction: float = 0.0, quantization: float = 0.0,
                        noise: float = 0.0, seed: int = 0, pd: tuple[float, float] | None = None):
    """Encoder position [m] at k = 0..N−1, from rest, for the commanded force u[k] (held, delayed by t_d).

    With ``pd = (K, B)`` the experiment runs under a weak PD wall, u[k] = force[k] − K·y[k] − B·(y[k] − y[k−1])/T
    on the measured (noisy, quantised) position y, and the answer is (u, y): the commanded force a lab records.
    """
    effects = Effects(delay={}, cable_mode={} if device.cable is not None else None)
    sp = sample_plant(build_plant(device, effects), device.sample_time, device.delay)
    step = FrictionStepper(sp, friction) if friction > 0 else linear_step(sp)
    x = np.zeros(sp.phi.shape[0])
    if friction > 0:
        step.reset(x)
    ip, d = sp.plant.motor_position, sp.d
    buf = np.zeros(d + 1)                       # buf[j] = u[k-1-j]
    y = np.empty(len(force))
    for k, u in enumerate(np.asarray(force, float)):
        y[k] = x[ip]
        ua = buf[d]
        ub = u if d == 0 else buf[d - 1]
        x, _ = step(x, ua, ub, 0.0)
        buf[1:] = buf[:-1]
        buf[0] = u
    rng = np.random.default_rng(seed + 1)
    if pd is not None:
        return _closed_loop(step, sp, np.asarray(force, float), pd, quantization, noise, rng, friction > 0)
    if noise > 0:
        y = y + rng.normal(0.0, noise, len(y))
    if quantization > 0:
        y = quantization * np.round(y / quantization)
    return y


def _closed_loop(step, sp, r, pd, quantization, noise, rng, reset):
    k_p, b_d = pd
    t, ip, d = sp.sample_time, sp.plant.motor_position, sp.d
    x = np.zeros(sp.phi.shape[0])
    if reset:
        step.reset(x)
    buf = np.zeros(d + 1)
    e = rng.normal(0.0, noise, len(r)) if noise > 0 else np.zeros(len(r))
    u_rec, y_rec = np.empty(len(r)), np.empty(len(r))
    y_prev = 0.0
    for k in range(len(r)):
        y = x[ip] + e[k]
        if quantization > 0:
            y = quantization * np.round(y / quantization)
        u = r[k] - k_p * y - b_d * (y - y_prev) / t
        y_prev = y
        u_rec[k], y_rec[k] = u, y
        ua = buf[d]
        ub = u if d == 0 else buf[d - 1]
        x, _ = step(x, ua, ub, 0.0)
        buf[1:] = buf[:-1]
        buf[0] = u
    return u_rec, y_rec
