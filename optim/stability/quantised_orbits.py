"""Exact periodic orbits of the quantised wall without Coulomb friction (issue 31).

Without friction the plant between samples is linear, and the only nonlinearity is the encoder's
mid-tread quantiser u_k = round(y_k/q) (y the sampled motor-side position).  The controller
C(z) = K + B·V(z) (+ M·A(z), the velocity filter of models.velocity_filter) acts on q·u, so the
position in counts obeys, for any periodic count sequence u of period N,

    y/q = −L(z)·u,   L(e^{jθ}) = G_n(e^{jθ})·(κ + β·V_n(θ) + μ·A_n(θ))   (dimensionless),

with G_n zwidth's sampled plant (ZOH, delay and cable mode exact: models.plants.stiffness_loop_plant),
κ = KT²/m, β = BT/m, μ = M/m.  A half-wave symmetric sequence (u_{k+N/2} = −u_k) has only odd
harmonics, so its periodic response is y = −q·IDFT(L(2πn/N)·U_n) exactly (the integrator at θ = 0 meets
a zero mean).  The sequence is a periodic orbit of the closed loop if and only if round(y_k/q) = u_k
for every k: a finite check, no approximation.  A found orbit with every y_k at least ``margin`` counts
from a rounding threshold persists under perturbations smaller than that margin (with u fixed the
perturbation evolves open loop: the velocity and cable modes decay, the position offset is neutral),
so it is an attracting (Lyapunov-stable) set: a sustained oscillation at the encoder's scale, which the
sinusoidal describing function misses where the true waveform (a three-level force pulse train) is far
from a sinusoid.

The search is not exhaustive: the candidate sequences are quantised sinusoids of several amplitudes
and phases for even periods from half to three times the loop's phase-crossover period, each iterated
u ← round(y(u)/q) a few times.  A found orbit is exact; no orbit found is not a proof that none exists.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.velocity_filter import Rendering
from optim.stability.margins import loop_plant

__all__ = ["Orbit", "find_orbits", "ORBIT_MARGIN"]

#: counts: a found orbit's positions must clear every rounding threshold by this much (robust to rounding and
#: to the simulation's event tolerances)
ORBIT_MARGIN = 1e-6
_AMPLITUDES = (0.55, 0.65, 0.75, 0.9, 1.1, 1.3, 1.6, 2.0, 2.5, 3.2, 4.0)
_PHASES = 4
_ITER = 8
_N_MIN_MAX = 64
_N_CAP = 2000
#: periods searched: from 0.5 to 3 times the linear loop's phase-crossover period 2π/θ_cr (the orbits found on
#: the random walls of docs/quantisation_runs.md have 0.85-1.4 times it), about this many of them
_SPAN = (0.5, 3.0)
_PERIODS = 120


@dataclass(frozen=True)
class Orbit:
    period: int
    """N [samples]."""
    amplitude: float
    """[m] half peak-to-peak of the sampled position y."""
    frequency_hz: float
    """1/(N·T) [Hz]."""
    levels: int
    """the largest |u| [counts] the force takes."""
    margin: float
    """[counts] the smallest distance of a y_k/q to a rounding threshold."""
    counts: tuple[int, ...] = ()
    """u_0 … u_{N−1}: the measured position in counts over one period (the force is −q·C(z)·u)."""


def _loop(device: Device, stiffness: float, damping: float, rendering: Rendering | None):
    plant = loop_plant(device)
    t, m = device.sample_time, device.mass
    kappa, beta = stiffness * t * t / m, damping * t / m
    mu = 0.0 if rendering is None else rendering.mass / m

    def l_of(theta: np.ndarray) -> np.ndarray:
        if rendering is None:
            h = kappa + beta * -np.expm1(-1j * theta)
        else:
            h = kappa + rendering.controller_response(theta, beta, mu)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return h / plant.inverse_response(theta)
    return l_of


def _response(u: np.ndarray, lv: np.ndarray, n: int) -> np.ndarray:
    """y/q = −L·u over one period, each row of u a period of counts."""
    spec = np.fft.rfft(u, axis=1)
    spec[:, 0] = 0.0
    spec[:, 1:] *= -lv[None, :]
    return np.fft.irfft(spec, n, axis=1)


def find_orbits(device: Device, stiffness: float, damping: float, crossover_angle: float | None,
                rendering: Rendering | None = None) -> list[Orbit]:
    """Exact half-wave symmetric periodic orbits of the frictionless quantised wall (module docstring), found by
    the candidate search; [] when the device has no encoder resolution."""
    q = device.encoder_resolution
    if q is None:
        return []
    n_cr = 2 * math.pi / crossover_angle if crossover_angle else _N_MIN_MAX
    n_max = int(min(_N_CAP, max(_N_MIN_MAX, _SPAN[1] * n_cr)))
    n_min = max(4, 2 * int(_SPAN[0] * n_cr / 2))
    step = max(2, 2 * int(round(n_cr / _PERIODS)))
    l_of = _loop(device, stiffness, damping, rendering)
    found: dict[tuple, Orbit] = {}
    amps = np.array(_AMPLITUDES)
    for n in range(n_min, n_max + 1, step):
        theta = 2 * math.pi * np.arange(1, n // 2 + 1) / n
        lv = l_of(theta)
        if not np.all(np.isfinite(lv)):
            continue
        k = np.arange(n)
        phases = 2 * math.pi * (np.arange(_PHASES) / _PHASES) / n
        u = np.round(amps[:, None, None] * np.sin(2 * math.pi * k[None, None, :] / n + phases[None, :, None]))
        u = u.reshape(-1, n)
        for _ in range(_ITER):
            y = _response(u, lv, n)
            nxt = np.round(y)
            if np.all(nxt == u):
                break
            u = nxt
        u = u[np.all(np.abs(u) <= 2 * amps[-1], axis=1)]
        y = _response(u, lv, n)
        fixed = np.all(np.round(y) == u, axis=1) & np.any(u != 0, axis=1)
        half = np.all(u[:, n // 2:] == -u[:, :n // 2], axis=1)
        for i in np.nonzero(fixed & half)[0]:
            margin = float(np.min(0.5 - np.abs(y[i] - u[i])))
            if margin < ORBIT_MARGIN:
                continue
            key = (n, tuple(np.roll(u[i], -int(np.argmax(u[i])))))
            if key in found:
                continue
            found[key] = Orbit(n, 0.5 * float(np.ptp(y[i])) * q, 1.0 / (n * device.sample_time),
                               int(np.max(np.abs(u[i]))), margin, tuple(int(v) for v in u[i]))
    # an orbit of period N repeated is one of period 2N, 3N…: keep the fundamental
    out: list[Orbit] = []
    for o in sorted(found.values(), key=lambda o: o.period):
        if not any(o.period % p.period == 0 and abs(o.amplitude - p.amplitude) <= 1e-9 * q for p in out):
            out.append(o)
    return out
