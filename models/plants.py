"""Continuous-time plants of the chapter and their sampled forms for the stiffness loop."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.discretize import RigidZOH, StateSpaceZOH, cable_state_space, split_delay
from models.errors import InputError

__all__ = ["TransferFunction", "rigid_tf", "cable_tfs", "stiffness_loop_plant", "Q_criterion"]


@dataclass(frozen=True)
class TransferFunction:
    """num(s)/den(s), coefficients highest power first (SI units)."""

    num: tuple[float, ...]
    den: tuple[float, ...]

    def __call__(self, s: np.ndarray | complex) -> np.ndarray:
        return np.polyval(self.num, s) / np.polyval(self.den, s)


def rigid_tf(mass: float, damping: float) -> TransferFunction:
    """G(s) = 1/(ms² + bs), eq. 14."""
    return TransferFunction((1.0,), (mass, damping, 0.0))


def cable_tfs(device: Device) -> dict[str, TransferFunction]:
    """G_d, G_c, G_r of eq. 15-18 for a device with a cable block."""
    c = device.cable
    if c is None:
        raise InputError("cable", "this device has no cable block")
    p_r = np.array([c.motor_mass, c.motor_damping + c.damping, c.stiffness])
    p_d = np.array([c.body_mass, c.body_damping + c.damping, c.stiffness])
    link = np.array([c.damping, c.stiffness])
    p: np.ndarray = np.polysub(np.polymul(p_r, p_d), np.polymul(link, link))
    den = tuple(float(v) for v in p)
    return {
        "G_d": TransferFunction(tuple(float(v) for v in p_r), den),
        "G_c": TransferFunction(tuple(float(v) for v in link), den),
        "G_r": TransferFunction(tuple(float(v) for v in p_d), den),
    }


def stiffness_loop_plant(device: Device) -> RigidZOH | StateSpaceZOH:
    """Z[H(s) G_r(s) e^{-t_d s}] · m/T² (eq. 20-21), dimensionless.

    Rigid devices use the closed form; cable devices the exact state-space
    form with the motor-side (collocated) output.
    """
    d, f = split_delay(device.delay_samples)
    if device.cable is None:
        return RigidZOH(delta=device.delta, d=d, f=f)
    c, m, t = device.cable, device.mass, device.sample_time
    a, b, cc = cable_state_space(
        mu_r=c.motor_mass / m, mu_d=c.body_mass / m,
        delta_r=c.motor_damping * t / m, delta_d=c.body_damping * t / m,
        kappa=c.stiffness * t * t / m, delta_c=c.damping * t / m)
    # Anti-resonance of G_r: the roots of p_d(s), as angles per sample (found when first asked for)
    return StateSpaceZOH(a=a, b=b, c=cc, d=d, f=f, zeros_poly=(c.body_mass, c.body_damping + c.damping, c.stiffness),
                         zeros_scale=t)


def Q_criterion(device: Device) -> float:
    """Q ≈ m_r z_n ω_n (eq. 22-24) [N/m]: the resonant peak's distance to 0 dB."""
    c = device.cable
    if c is None:
        raise InputError("cable", "the Q criterion needs a cable block")
    m_r, m_d = c.motor_mass, c.body_mass
    z_n = (c.motor_damping + c.damping) / m_r + (c.body_damping + c.damping) / m_d \
        - (c.motor_damping + c.body_damping) / (m_r + m_d)
    return m_r * z_n * c.natural_frequency
