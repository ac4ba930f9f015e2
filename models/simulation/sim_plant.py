"""The continuous plant a scene calls for, in physical units, and its exact sampled form.

Only the named effects enter the model (models/simulation/scene.py):
  * rigid (eq. 14) or, with ``cable_mode``, the two-mass model of eq. 15-18 with
    physical states [x_r, x_d, v_r, v_d] (motor force on m_r, user force on m_d);
  * ``human``: Z_h = m_h s² + b_h s + k_h (eq. 30) rigidly attached to the body
    mass (its mass, damping and stiffness to ground add to the body's);
  * ``force_sensor_filter``: one more state s with T_f ṡ = F_u - s (eq. 31), where
    F_u is the force the hand puts on the device, F_u = F_h - m_h ẍ_d - b_h ẋ_d - k_h x_d.

The sampled form is the exact ZOH with the loop delay t_d = (d + f)T on the motor
force (never on the user's force) built with scipy.linalg.expm of one augmented
matrix per sub-interval, the same construction as models/discretize.py but in SI
units (tests/models/simulation/test_sim_plant.py checks the two agree):

    x[k+1] = Φ x[k] + Γ0 u[k-d] + Γ1 u[k-d-1] + Γh w[k].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from models.device import Device
from models.discretize import split_delay
from models.errors import InputError
from models.simulation.scene import Effects

__all__ = ["ContinuousPlant", "SampledPlant", "build_plant", "sample_plant", "SceneModelError"]


class SceneModelError(InputError):
    """The scene names an effect the device cannot provide (an InputError: field and rule)."""

    def __reduce__(self):
        return (SceneModelError, (self.field, self.rule))


@dataclass(frozen=True)
class ContinuousPlant:
    """ẋ = A x + b_motor F_m + b_user F_h (SI units)."""

    a: np.ndarray
    b_motor: np.ndarray
    b_user: np.ndarray
    motor_position: int
    """index of the encoder (motor-side) position."""
    motor_velocity: int
    body_position: int
    motor_side_mass: float
    """[kg] mass of the motor-side velocity state (where Coulomb friction acts)."""
    sensor: int | None
    """index of the force-sensor filter state, when simulated."""


@dataclass(frozen=True)
class SampledPlant:
    """Exact ZOH of a ContinuousPlant with a delay of d whole samples plus a fraction f."""

    plant: ContinuousPlant
    sample_time: float
    d: int
    f: float
    phi: np.ndarray
    gamma0: np.ndarray
    gamma1: np.ndarray
    gamma_user: np.ndarray
    mid_phi: np.ndarray
    """e^{A fT}: state at kT + fT (where the applied force switches) from x[k]."""
    mid_motor: np.ndarray
    """Ψ(fT) b_motor: effect of the force held during the first f of the period."""
    mid_user: np.ndarray


def _rigid(device: Device, human) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int, int, float]:
    mass, damp, k = device.mass, device.damping, 0.0
    if human is not None:
        mass, damp, k = mass + human.mass, damp + human.damping, human.stiffness
    a = np.array([[0.0, 1.0], [-k / mass, -damp / mass]])
    b = np.array([0.0, 1.0 / mass])
    return a, b, b.copy(), 0, 1, 0, mass


def _cable(device: Device, human) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int, int, float]:
    c = device.cable
    assert c is not None, "_cable is called for a device with a cable block"
    m_r, b_r, m_d, b_d, k_c, b_c = c.motor_mass, c.motor_damping, c.body_mass, c.body_damping, c.stiffness, c.damping
    k_h = 0.0
    if human is not None:
        m_d, b_d, k_h = m_d + human.mass, b_d + human.damping, human.stiffness
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1.0
    a[2] = [-k_c / m_r, k_c / m_r, -(b_r + b_c) / m_r, b_c / m_r]
    a[3] = [k_c / m_d, -(k_c + k_h) / m_d, b_c / m_d, -(b_d + b_c) / m_d]
    return a, np.array([0.0, 0.0, 1.0 / m_r, 0.0]), np.array([0.0, 0.0, 0.0, 1.0 / m_d]), 0, 2, 1, m_r


def build_plant(device: Device, effects: Effects) -> ContinuousPlant:
    """The continuous model with exactly the named effects."""
    human = None
    if effects.human is not None:
        if device.human is None:
            raise SceneModelError("scene.effects.human", "the device has no human block")
        human = device.human
    if effects.cable_mode is not None:
        if device.cable is None:
            raise SceneModelError("scene.effects.cable_mode", "the device has no cable block")
        a, bm, bu, ip, iv, ib, m_f = _cable(device, human)
    else:
        a, bm, bu, ip, iv, ib, m_f = _rigid(device, human)
    sensor = None
    if effects.force_sensor_filter is not None:
        fs = device.force_sensor
        if fs is None or fs.time_constant <= 0.0:
            raise SceneModelError("scene.effects.force_sensor_filter",
                                  "the device has no force sensor with time_constant > 0")
        n = a.shape[0]
        vel_body = n // 2 + ib                   # body velocity state (positions first, then velocities)
        m_h = human.mass if human else 0.0
        b_h = human.damping if human else 0.0
        k_h = human.stiffness if human else 0.0
        # F_u = F_h - m_h·ẍ_d - b_h·ẋ_d - k_h·x_d, with ẍ_d the body row of the device model.
        fu_x = -m_h * a[vel_body] - b_h * np.eye(n)[vel_body] - k_h * np.eye(n)[ib]
        fu_m = -m_h * bm[vel_body]
        fu_h = 1.0 - m_h * bu[vel_body]
        tf = fs.time_constant
        big = np.zeros((n + 1, n + 1))
        big[:n, :n] = a
        big[n, :n] = fu_x / tf
        big[n, n] = -1.0 / tf
        a = big
        bm = np.append(bm, fu_m / tf)
        bu = np.append(bu, fu_h / tf)
        sensor = n
    return ContinuousPlant(a=a, b_motor=bm, b_user=bu, motor_position=ip, motor_velocity=iv,
                           body_position=ib, motor_side_mass=m_f, sensor=sensor)


def exp_affine(a: np.ndarray, inputs: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^{At}, Ψ(t)·inputs) from one augmented matrix exponential; inputs is (n, m)."""
    n, m = inputs.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n] = a
    big[:n, n:] = inputs
    e = expm(big * t)
    return e[:n, :n], e[:n, n:]


def sample_plant(plant: ContinuousPlant, sample_time: float, delay: float) -> SampledPlant:
    """Exact ZOH with the motor force delayed by ``delay`` seconds (any real ≥ 0)."""
    d, f = split_delay(delay / sample_time)
    t = sample_time
    inputs = np.column_stack([plant.b_motor, plant.b_user])
    phi, g = exp_affine(plant.a, inputs, t)
    e0, g0 = exp_affine(plant.a, inputs, (1.0 - f) * t)
    if f > 0.0:
        ef, gf = exp_affine(plant.a, inputs, f * t)
        gamma1 = e0 @ gf[:, 0]
    else:
        ef, gf = np.eye(plant.a.shape[0]), np.zeros_like(inputs)
        gamma1 = np.zeros(plant.a.shape[0])
    return SampledPlant(plant=plant, sample_time=t, d=d, f=f, phi=phi, gamma0=g0[:, 0], gamma1=gamma1,
                        gamma_user=g[:, 1], mid_phi=ef, mid_motor=gf[:, 0], mid_user=gf[:, 1])
