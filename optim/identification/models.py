"""The two model structures (rigid, cable) and their outputs, built on the project's own plants.

A parameter vector θ (SI units, in the order of :data:`PARAMS`) becomes a validated
``models.device.Device``; its sampled form is ``models.plants.stiffness_loop_plant`` — the very
RigidZOH / StateSpaceZOH the stability analyses use (exact ZOH, delay split into whole samples and an
exact fraction) — so an identified device and its analysis can never disagree about the model.

Time series: the motor force u[k] (held by the ZOH, delayed by t_d) drives the plant; the encoder reads
the motor-side position.  The sampled plant is written in its modal form (an exact integrator plus
first-order modes, StateSpaceZOH.modal_form), so a record of N samples costs a few scipy.signal.lfilter
passes and one cumsum: O(N), no Python loop over samples.

Frequency response: X/F(jω) of the continuous mechanics times e^{−jωt_d} (``continuous``), or the
sampled loop's own response G(e^{jωT}) (``sampled``: force sample to encoder sample, ZOH included).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from scipy.signal import lfilter

from models.device import Device
from models.discretize import RigidZOH
from models.plants import cable_tfs, stiffness_loop_plant

__all__ = ["PARAMS", "POSITIVE", "ModelName", "device_from", "modal_terms", "response", "simulate_position"]

ModelName = Literal["rigid", "cable"]

PARAMS: dict[str, tuple[str, ...]] = {
    "rigid": ("mass", "damping", "delay"),
    "cable": ("cable.motor_mass", "cable.motor_damping", "cable.body_mass", "cable.body_damping",
              "cable.stiffness", "cable.damping", "delay"),
}
#: parameters that must stay > 0 (the others ≥ 0)
POSITIVE = frozenset({"mass", "cable.motor_mass", "cable.body_mass", "cable.stiffness"})


def device_from(model: ModelName, values: dict[str, float], sample_time: float) -> Device:
    """The validated Device of a parameter set (names as in PARAMS)."""
    if model == "rigid":
        return Device(mass=values["mass"], damping=values["damping"], sample_time=sample_time,
                      delay=values["delay"])
    cable = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("cable.")}
    return Device(cable=cable, sample_time=sample_time, delay=values["delay"])


def modal_terms(device: Device):
    """(d, λ, c1, c2v, e12v, r0, r1, g0_1, g1_1): the sampled plant as integrator + modes (dimensionless).

    x₁[k+1] = x₁[k] + e12v·w[k] + g0_1 u[k−d] + g1_1 u[k−d−1],  w_i[k+1] = (1 + λ_i) w_i[k] + r0_i u[k−d] + r1_i u[k−d−1],
    y = c1 x₁ + c2v·w, with u in units of m/T² (the plant's own scaling).  None when the modes are not
    well conditioned (then :func:`simulate_position` steps the state-space form).
    """
    plant = stiffness_loop_plant(device)
    if isinstance(plant, RigidZOH):
        one_minus_p, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
        return (plant.d, np.array([-one_minus_p]), 1.0, np.array([0.0]), np.array([phi12]),
                np.array([g0v]), np.array([g1v]), g0p, g1p)
    modal = plant.modal_form()
    if modal is None:
        return None
    return (plant.d,) + tuple(modal)


def _delayed(u: np.ndarray, d: int) -> np.ndarray:
    if d == 0:
        return u
    out = np.zeros_like(u)
    if d < len(u):
        out[d:] = u[:-d]
    return out


def simulate_position(device: Device, force: np.ndarray) -> np.ndarray:
    """Encoder position [m] at samples k = 0..N−1 for the held force u[k] [N], from rest at 0.

    x[k] depends on u[0..k−1] (the force commanded at sample k acts from kT + t_d on)."""
    u = np.asarray(force, float) * (device.sample_time ** 2 / device.mass)
    terms = modal_terms(device)
    if terms is None:
        return _step_state_space(device, u)
    d, lam, c1, c2v, e12v, r0, r1, g0_1, g1_1 = terms
    ud = _delayed(u, d)
    n = len(ud)
    w = np.empty((len(lam), n), dtype=complex if np.iscomplexobj(lam) else float)
    for i, li in enumerate(lam):
        w[i] = lfilter([0.0, r0[i], r1[i]], [1.0, -(1.0 + li)], ud)
    inc = np.zeros(n)
    inc[1:] = g0_1 * ud[:-1] + np.real(e12v @ w[:, :-1])
    if n > 2:
        inc[2:] += g1_1 * ud[:-2]
    x1 = np.cumsum(inc)
    y = c1 * x1 + np.real(c2v @ w)
    return y


def _step_state_space(device: Device, u: np.ndarray) -> np.ndarray:
    """Fallback for an ill-conditioned modal form: the exact (Φ, Γ0, Γ1) recursion, sample by sample."""
    plant = stiffness_loop_plant(device)
    phi, g0, g1, c = plant.matrices()
    ud = _delayed(u, plant.d)
    x = np.zeros(phi.shape[0])
    y = np.empty(len(u))
    prev = 0.0
    for k in range(len(u)):
        y[k] = c @ x
        x = phi @ x + g0 * ud[k] + g1 * prev
        prev = ud[k]
    return y


def response(device: Device, omega: np.ndarray, kind: Literal["continuous", "sampled"]) -> np.ndarray:
    """X/F [m/N] at ω [rad/s], delay included (see the module docstring for the two kinds)."""
    omega = np.asarray(omega, float)
    if kind == "sampled":
        t = device.sample_time
        return stiffness_loop_plant(device).response(omega * t) * (t * t / device.mass)
    s = 1j * omega
    if device.cable is None:
        g = 1.0 / (s * (device.mass * s + device.damping))
    else:
        g = cable_tfs(device)["G_r"](s)
    return g * np.exp(-s * device.delay)
