"""Exact periodic solutions of a relay on a sampled loop (Åström–Hägglund relay, chapter §4.4).

The sampled open loop from the relay's command u[k] to the measured position y[k]
is z[k+1] = F z[k] + g u[k], y = h·z, with z = [plant state, u[k-1] … u[k-d-1]]
(the delay line is part of the state, so the sign conditions below already
"mind the delay").  The relay commands u = -a·sign(y).

A switching pattern (half-period lengths n_1 … n_P, the command alternating
+a, -a, …) fixes the input sequence, so the periodic state solves a linear
system: with L = Σ n_i, z(L) = -z(0) when P is odd (anti-periodic, the next
pattern repeats with the opposite sign) or z(L) = z(0) when P is even (then the
rigid-body integrator leaves the mean position free; the minimum-norm solution
is taken and the first harmonic, which a constant offset does not change, is
what is compared).  A symmetric cycle of half period N is the pattern (N,):
x = -(state after N steps of +a from x).  It is *admissible* when the relay
would really command it: y[k] < 0 on every sample of the +a half period.

First harmonics are the DFT bin of the fundamental over one full period of the
sampled sequences (what a lab computes from logged data), so for a periodic
solution K_u = |U₁|/|Y₁| = 1/|G(e^{jω T})| exactly, G being the pulse transfer
from command to measured position (tests check this against models/discretize).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.simulation.sim_plant import SampledPlant

__all__ = ["RelayLoop", "PeriodicSolution", "relay_loop", "pattern_solution", "symmetric_cycles"]


@dataclass(frozen=True)
class RelayLoop:
    """z[k+1] = F z[k] + g u[k], y[k] = h·z[k] (SI units; u in N, y in m)."""

    f: np.ndarray
    g: np.ndarray
    h: np.ndarray
    sample_time: float


@dataclass(frozen=True)
class PeriodicSolution:
    """The exact periodic motion of one switching pattern."""

    pattern: tuple[int, ...]
    """half-period lengths [samples], starting with the +a half."""
    period_samples: int
    frequency: float
    """ω = 2π/(period·T) [rad/s]."""
    force_amplitude: float
    """|U₁| [N], first harmonic of the command."""
    position_amplitude: float
    """|Y₁| [m], first harmonic of the measured position."""
    ultimate_gain: float
    """K_u = |U₁|/|Y₁| [N/m]."""
    admissible: bool
    """the relay's sign condition holds on every sample (y < 0 under +a, y > 0 under -a)."""
    sign_margin: float
    """[m] the smallest |y| on the samples of the period, signed: < 0 when a condition fails."""
    state: np.ndarray
    """z at the first switch to +a."""


def relay_loop(sp: SampledPlant) -> RelayLoop:
    """The open loop of models.simulation.sim_plant's sampled plant with its delay line as state."""
    n, d = sp.phi.shape[0], sp.d
    nb = d + 1
    f = np.zeros((n + nb, n + nb))
    g = np.zeros(n + nb)
    f[:n, :n] = sp.phi
    f[:n, n + d] += sp.gamma1                   # u[k-d-1], first f of the period
    if d == 0:
        g[:n] += sp.gamma0
    else:
        f[:n, n + d - 1] += sp.gamma0           # u[k-d]
    g[n] = 1.0
    for j in range(1, nb):
        f[n + j, n + j - 1] = 1.0
    h = np.zeros(n + nb)
    h[sp.plant.motor_position] = 1.0
    return RelayLoop(f=f, g=g, h=h, sample_time=sp.sample_time)


def _inputs(pattern: tuple[int, ...], amplitude: float) -> np.ndarray:
    return np.concatenate([np.full(n, amplitude * (1 if i % 2 == 0 else -1)) for i, n in enumerate(pattern)])


def _harmonic(seq: np.ndarray) -> complex:
    k = np.arange(len(seq))
    return complex(np.sum(seq * np.exp(-2j * math.pi * k / len(seq)))) * 2.0 / len(seq)


def pattern_solution(loop: RelayLoop, pattern: tuple[int, ...], amplitude: float) -> PeriodicSolution:
    """Exact periodic solution of a switching pattern (module docstring)."""
    u = _inputs(pattern, amplitude)
    length = len(u)
    m = np.eye(len(loop.g))
    r = np.zeros(len(loop.g))
    for uk in u:
        r = loop.f @ r + loop.g * uk
        m = loop.f @ m
    anti = len(pattern) % 2 == 1
    if anti:
        z0 = np.linalg.solve(np.eye(len(r)) + m, -r)
    else:
        z0 = np.linalg.lstsq(np.eye(len(r)) - m, r, rcond=None)[0]
    ys = np.empty(length)
    z = z0
    for k, uk in enumerate(u):
        ys[k] = loop.h @ z
        z = loop.f @ z + loop.g * uk
    if anti:
        u_full, y_full = np.concatenate([u, -u]), np.concatenate([ys, -ys])
    else:
        u_full, y_full = u, ys
    u1, y1 = abs(_harmonic(u_full)), abs(_harmonic(y_full))
    margin = float(np.min(-np.sign(u) * ys))
    return PeriodicSolution(pattern=tuple(int(n) for n in pattern), period_samples=len(u_full),
                            frequency=2 * math.pi / (len(u_full) * loop.sample_time), force_amplitude=u1,
                            position_amplitude=y1, ultimate_gain=u1 / y1, admissible=margin > 0,
                            sign_margin=margin, state=z0)


def symmetric_cycles(loop: RelayLoop, amplitude: float, max_half_period: int) -> list[PeriodicSolution]:
    """Every symmetric cycle with half period N = 1 … max_half_period, admissible or not, in one sweep.

    F^N, S_N = Σ_{i<N} F^i g and the rows h F^k, h S_k are built incrementally, so
    each N costs one linear solve and one product over its N samples.
    """
    size = len(loop.g)
    hf = np.empty((max_half_period, size))
    hs = np.empty(max_half_period)
    fn, sn = np.eye(size), np.zeros(size)
    out: list[PeriodicSolution] = []
    eye = np.eye(size)
    for nh in range(1, max_half_period + 1):
        hf[nh - 1] = loop.h @ fn
        hs[nh - 1] = loop.h @ sn
        sn = loop.f @ sn + loop.g
        fn = loop.f @ fn
        try:
            z0 = np.linalg.solve(eye + fn, -amplitude * sn)
        except np.linalg.LinAlgError:
            continue
        ys = hf[:nh] @ z0 + hs[:nh] * amplitude
        margin = float(np.min(-ys))
        y_full = np.concatenate([ys, -ys])
        u_full = np.concatenate([np.full(nh, amplitude), np.full(nh, -amplitude)])
        u1, y1 = abs(_harmonic(u_full)), abs(_harmonic(y_full))
        out.append(PeriodicSolution(pattern=(nh,), period_samples=2 * nh,
                                    frequency=math.pi / (nh * loop.sample_time), force_amplitude=u1,
                                    position_amplitude=y1, ultimate_gain=u1 / y1 if y1 > 0 else math.inf,
                                    admissible=margin > 0, sign_margin=margin, state=z0))
    return out
