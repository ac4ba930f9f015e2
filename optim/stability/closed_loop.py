"""Closed-loop state matrices of the sampled stiffness loop, built without the crossover scan's code.

The independent side of ``verify`` (optim/verification.py).  Nothing here imports models.discretize,
models.plants, optim.stability.crossovers or optim.stability.margins: the device's continuous-time state space is written
out again from its physical parameters, discretised by one matrix exponential of an augmented matrix
(scipy.linalg.expm), and closed with the wall C(z) = K + B(1 − z⁻¹)/T, the whole-sample delay as a
shift register of past forces and the fractional part through the two input matrices of the
augmented discretisation.

Everything is dimensionless (time in samples, masses in units of m: K → α = KT²/m, B → β = BT/m).

Numerical form.  The poles that decide stability cluster near z = 1 when δ = bT/m is tiny (the
crossover sits at θ ≈ √(δ/(d+½))), and |z| − 1 is then of order ε·δ.  So the matrix is assembled as
Q = M − I (the delta operator), with Φ − I = A·Ψ(1) taken from the exponential (never Φ minus I in
floating point), and |z| − 1 is computed from the eigenvalues q of Q as (2 Re q + |q|²)/(|1 + q| + 1),
which keeps its relative precision where 1 + q would round it away.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eig, expm, matrix_balance

from models.device import Device
from optim.stability.circle_reach import precise_correction

__all__ = [
    "circle_poles",
    "RadiusExcess",
    "SampledPlant",
    "UnstableCount",
    "count_outside",
    "discretise",
    "plant_response",
    "plant_rounding",
    "radius_excess",
    "sampled_plant",
    "split_delay_samples",
    "stiffness_closed_loop",
    "unstable_count",
]


@dataclass(frozen=True)
class SampledPlant:
    """x[k+1] = x[k] + E x[k] + Γ0 u[k−d] + Γ1 u[k−d−1], y = c·x (dimensionless)."""

    e: np.ndarray
    """Φ − I."""
    g0: np.ndarray
    g1: np.ndarray
    c: np.ndarray
    d: int
    """whole samples of delay."""
    f: float
    """fraction of a sample of delay, in [0, 1)."""


def _continuous(device: Device) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C) from force to the motor-side position, time in samples, masses in units of m."""
    m, t = device.mass, device.sample_time
    cb = device.cable
    if cb is None:
        # x'' = u − δ x'
        return np.array([[0.0, 1.0], [0.0, -device.delta]]), np.array([0.0, 1.0]), np.array([1.0, 0.0])
    mr, md = cb.motor_mass / m, cb.body_mass / m
    br, bd, bc = cb.motor_damping * t / m, cb.body_damping * t / m, cb.damping * t / m
    kc = cb.stiffness * t * t / m
    # states x_r, v (centre-of-mass velocity μ_r v_r + μ_d v_d), e = x_d − x_r, w = v_d − v_r: the motor
    # position is a pure integrator (a zero column) and, without damping to ground, v is one too (a zero
    # row), so the open-loop poles at z = 1 are exact zeros of E, not rounding-sized ones.
    a = np.array([[0.0, 1.0, 0.0, -md],
                  [0.0, -(br + bd), 0.0, -(bd * mr - br * md)],
                  [0.0, 0.0, 0.0, 1.0],
                  [0.0, (br / mr - bd / md), -kc / md - kc / mr,
                   -(bd * mr) / md - bc / md - bc / mr - br * md / mr]])
    return a, np.array([0.0, 1.0, 0.0, -1.0 / mr]), np.array([1.0, 0.0, 0.0, 0.0])


def _split(samples: float) -> tuple[int, float]:
    # a fraction within a few ulp of a whole sample is that sample (0.003/0.001 = 2.9999999999999996)
    whole = round(samples)
    if abs(samples - whole) <= 64 * np.finfo(float).eps * max(1.0, samples):
        return int(whole), 0.0
    return int(math.floor(samples)), float(samples - math.floor(samples))


#: (whole, fraction) of a delay in samples, a fraction within a few ulp of a whole sample snapped to it
split_delay_samples = _split


def _psi(a: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^{Aσ}, Ψ(σ) = ∫₀^σ e^{As} ds) from one exponential of [[A, I], [0, 0]]·σ."""
    n = a.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = a
    big[:n, n:] = np.eye(n)
    ex = expm(big * sigma)
    return ex[:n, :n], ex[:n, n:]


def discretise(a: np.ndarray, b: np.ndarray, c: np.ndarray, delay_samples: float) -> SampledPlant:
    """Zero-order hold with a delay (d + f)·T: Γ0 acts over the last 1 − f of a period, Γ1 over the first f."""
    d, f = _split(delay_samples)
    _, psi1 = _psi(a, 1.0)
    e = a @ psi1
    if f == 0.0:
        return SampledPlant(e, psi1 @ b, np.zeros_like(b), c, d, 0.0)
    ex_late, psi_late = _psi(a, 1.0 - f)
    _, psi_early = _psi(a, f)
    return SampledPlant(e, psi_late @ b, ex_late @ psi_early @ b, c, d, f)


def sampled_plant(device: Device) -> SampledPlant:
    """The stiffness loop's plant (force to motor-side position), sampled."""
    a, b, c = _continuous(device)
    p = discretise(a, b, c, device.delay / device.sample_time)
    p.e[:, 0] = 0.0   # nothing depends on the motor position itself (A's first column is zero)
    return p


def stiffness_closed_loop(plant: SampledPlant, alpha: float, beta: float) -> np.ndarray:
    """Q = M − I of the closed loop with u[k] = −(α y[k] + β (y[k] − y[k−1])).

    State s = [x, y[k−1], u[k−1], …, u[k−L]] with L = d + 1 when the delay has a fraction (Γ1 ≠ 0),
    L = d otherwise.  Its size is n + 1 + L.
    """
    n, d = plant.e.shape[0], plant.d
    chain = d + 1 if plant.f > 0.0 else d
    size = n + 1 + chain
    iy, iu = n, n + 1
    u = np.zeros(size)                          # u[k] as a row on the state
    u[:n] = -(alpha + beta) * plant.c
    u[iy] = beta
    q = np.zeros((size, size))
    add_plant_rows(q, plant, u, iu)
    q[iy, :n] = plant.c
    q[iy, iy] = -1.0
    add_delay_chain(q, u, iu, chain)
    return q


def add_plant_rows(q: np.ndarray, plant: SampledPlant, u: np.ndarray, iu: int) -> None:
    """The plant's rows of Q = M − I: x[k+1] − x[k] = (E − I) x + Γ0 u[k−d] + Γ1 u[k−d−1], with u[k] the row ``u``
    on the state and u[k−1], … stored from column ``iu`` on (the wall and the feedforward loop share it)."""
    n, d = plant.e.shape[0], plant.d
    q[:n, :n] = plant.e
    if d == 0:
        q[:n, :] += np.outer(plant.g0, u)
    else:
        q[:n, iu + d - 1] += plant.g0
    if plant.f > 0.0:
        q[:n, iu + d] += plant.g1


def add_delay_chain(q: np.ndarray, u: np.ndarray, iu: int, chain: int) -> None:
    """The shift register's rows of Q = M − I: u[k−1] takes the row ``u``, each later slot its predecessor."""
    if chain:
        q[iu, :] += u
        for j in range(chain):
            q[iu + j, iu + j] -= 1.0
            if j:
                q[iu + j, iu + j - 1] = 1.0


@dataclass(frozen=True)
class RadiusExcess:
    """max |z| − 1 over the closed-loop poles, with a first-order bound on its rounding error."""

    excess: float
    """spectral radius minus one (negative: stable)."""
    error: float
    """bound on the error of each |z| − 1: eps·‖Q_bal‖·(eigenvalue condition), times a safety factor."""
    decided_stable: bool
    """every pole is inside by more than its own error bound."""
    decided_unstable: bool
    """some pole is outside by more than its own error bound."""


_SAFETY = 100.0


def radius_excess(q: np.ndarray) -> RadiusExcess:
    """Spectral radius of I + Q minus one, from the eigenvalues of Q, with per-eigenvalue error bounds.

    The matrix is balanced first (scipy.linalg.matrix_balance) so that the norm in the bound is the
    one the QR algorithm actually sees; the condition of each eigenvalue is 1/|yᴴx| of its unit left
    and right eigenvectors (Wilkinson).
    """
    qb, _ = matrix_balance(q, permute=False)
    w, vl, vr = eig(qb, left=True, right=True)
    vl = vl / np.linalg.norm(vl, axis=0)
    vr = vr / np.linalg.norm(vr, axis=0)
    dots = np.abs(np.sum(vl.conj() * vr, axis=0))
    cond = 1.0 / np.maximum(dots, 1e-300)
    err = _SAFETY * np.finfo(float).eps * np.linalg.norm(qb, 2 if qb.shape[0] <= 400 else "fro") * cond
    mag = np.abs(1.0 + w)
    ex = (2.0 * w.real + (w.real ** 2 + w.imag ** 2)) / (mag + 1.0)
    i = int(np.argmax(ex))
    return RadiusExcess(excess=float(ex[i]), error=float(err[i]),
                        decided_stable=bool(np.all(ex + err < 0.0)),
                        decided_unstable=bool(np.any(ex - err > 0.0)))


# --- argument principle: the count of unstable poles, for any number of delay states -------------------

@dataclass(frozen=True)
class UnstableCount:
    """Closed-loop poles outside the unit circle, counted by the argument principle on the return difference."""

    count: int | None
    """None when the count could not be resolved (a pole within rounding of the circle)."""
    samples: int
    """evaluations of the return difference it took."""
    reason: str | None = None
    precise: str | None = None
    """the closed-loop poles within double precision's reach of the circle that were decided in mpmath (where and how
    far off the circle), None when there were none."""


_MAX_ROUNDS = 80


def _circle_poles(device: Device) -> tuple[int, tuple[float, ...]]:
    """Open-loop poles exactly on the unit circle, from the device's structure (not from rounding):
    the multiplicity at z = 1, and the angles in (0, π) of an undamped cable mode."""
    cb = device.cable
    if cb is None:
        return (2 if device.damping == 0.0 else 1), ()
    ground = cb.motor_damping + cb.body_damping
    if ground > 0.0:
        return 1, ()
    if cb.damping > 0.0:
        return 2, ()
    angle = cb.natural_frequency * device.sample_time
    folded = math.remainder(angle, 2 * math.pi)
    return 2, (abs(folded),)


def circle_poles(device: Device) -> tuple[int, tuple[float, ...]]:
    """The open-loop poles exactly on the unit circle (see ``count_outside``): z = 1's multiplicity, undamped angles."""
    return _circle_poles(device)


def plant_response(plant: SampledPlant, theta: np.ndarray) -> np.ndarray:
    """G(e^{iθ}) = z^{−d}·c((z − 1)I − E)⁻¹(Γ0 + Γ1 z⁻¹) at each θ [rad/sample], z − 1 computed without
    cancellation."""
    _, _, x = _resolvent_solve(plant, theta)
    return (x @ plant.c) * np.exp(-1j * plant.d * theta)


def _resolvent_solve(plant: SampledPlant, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(z − 1, (z − 1)I − E, x = ((z − 1)I − E)⁻¹(Γ0 + Γ1 z⁻¹)) at each θ, z − 1 without cancellation."""
    n = plant.e.shape[0]
    zm1 = -2.0 * np.sin(theta / 2) ** 2 + 1j * np.sin(theta)
    zinv = np.exp(-1j * theta)
    mats = zm1[:, None, None] * np.eye(n) - plant.e[None, :, :]
    rhs = plant.g0[None, :] + plant.g1[None, :] * zinv[:, None]
    return zm1, mats, np.linalg.solve(mats, rhs[:, :, None])[:, :, 0]


#: the a-priori rounding bound's constant (:func:`plant_rounding`): generous against the measured errors
_ROUNDING_K = 64.0


def plant_rounding(plant: SampledPlant, theta: np.ndarray) -> np.ndarray:
    """A bound on the error of the double G(e^{jθ}) (:func:`plant_response`) from the rounding of E, Γ0, Γ1 (the
    matrix exponential, backward stable: ~u·‖·‖ each) and of the solve: first order, normwise,
    K·u·‖cR‖·(‖E‖ + |z − 1|)·‖RΓ̃‖ + K·u·‖cR‖·(‖Γ0‖ + ‖Γ1‖), R = ((z − 1)I − E)⁻¹, Γ̃ = Γ0 + Γ1 z⁻¹.  Sharp beside a
    lightly damped mode (the pole's own rounding), pessimistic beside z = 1 (whose poles the structure keeps exact):
    it only decides when verify may skip the mpmath look (optim.stability.circle_reach)."""
    n = plant.e.shape[0]
    zm1, mats, x = _resolvent_solve(plant, theta)
    y = np.linalg.solve(np.swapaxes(mats, 1, 2), np.broadcast_to(plant.c.astype(complex), (theta.size, n))[:, :, None])
    ny, nx = np.linalg.norm(y[:, :, 0], axis=1), np.linalg.norm(x, axis=1)
    ne = np.linalg.norm(plant.e)
    ng = np.linalg.norm(plant.g0) + np.linalg.norm(plant.g1)
    return _ROUNDING_K * np.finfo(float).eps * ny * ((ne + np.abs(zm1)) * nx + ng)


def _return_difference(plant: SampledPlant, alpha: float, beta: float, theta: np.ndarray) -> np.ndarray:
    """F(e^{iθ}) = 1 + C(z)·G(z), G the plant's response (:func:`plant_response`)."""
    g = plant_response(plant, theta)
    ctrl = alpha + beta * (-np.expm1(-1j * theta))
    return 1.0 + ctrl * g


def unstable_count(device: Device, plant: SampledPlant, alpha: float, beta: float,
                   precise: Callable | None = None, digits: int = 50) -> UnstableCount:
    """Number of closed-loop poles outside the unit circle of the stiffness loop (see :func:`count_outside`);
    ``precise``: F(θ) in mpmath (optim.stability.closed_loop_mp), for the poles within double precision's reach."""
    m1, pair_angles = _circle_poles(device)

    def rounding(th: np.ndarray) -> np.ndarray:
        ctrl = np.abs(alpha + beta * (-np.expm1(-1j * th)))
        return ctrl * plant_rounding(plant, th) + 4.0 * np.finfo(float).eps * (1.0 + np.abs(
            _return_difference(plant, alpha, beta, th) - 1.0))
    return count_outside(lambda th: _return_difference(plant, alpha, beta, th), 1.0 + np.linalg.eigvals(plant.e),
                         plant.d, m1, pair_angles, precise, digits, rounding)


def count_outside(ret_diff, open_loop_poles: np.ndarray, d: int, m1: int,
                  pair_angles: tuple[float, ...] = (), precise: Callable | None = None,
                  digits: int = 50, rounding: Callable | None = None) -> UnstableCount:
    """Number of closed-loop poles outside the unit circle: Z_out = m_on − wind(F).

    F = 1 + L (``ret_diff(θ)`` = F(e^{jθ})) has the open-loop poles as its poles; those strictly inside do not
    count, those on the circle (``m1`` at z = 1, an undamped pair at ``pair_angles``) are passed on the inside
    by small indentations, each adding +π per multiplicity to arg F.  Real coefficients: the lower half
    circle mirrors the upper, so wind(F)·2π = 2·Δarg over the upper arcs + π·m1 + 2π·(pairs).
    The samples are refined by bisection wherever arg F turns by more than π/3 between neighbours.

    ``precise``: F(θ) in mpmath (``digits`` digits, θ an mpf).  Given, every closed-loop pole that double precision
    places within its own reach of the circle is decided in mpmath, and so is every arc that double precision
    cannot refine (optim.stability.circle_reach); without it, the count stands on double precision alone.
    ``rounding(θ)``: an a-priori bound on the double F's error, which spares the mpmath look at poles well beyond it.
    """
    dist0 = np.abs(open_loop_poles - 1.0)
    small = [float(v) for v in dist0 if v > 0.0]
    scale = min([1.0 / (1.0 + d)] + small)
    lo = 1e-3 * scale
    # the indentation's +π per multiplicity holds where the pole dominates F (|L| ≫ 1): a small gain
    # pushes that region towards z = 1
    for _ in range(60 if m1 else 0):
        if abs(ret_diff(np.array([lo]))[0] - 1.0) > 1e8 or lo < 1e-280:
            break
        lo *= 1e-2
    cuts = [lo]
    for ang in pair_angles:
        if not (1e-9 < ang < math.pi - 1e-9):
            return UnstableCount(None, 0, "an undamped mode sits at z = ±1: the indentation cannot be placed")
        rho = 1e-9 * ang
        cuts += [ang - rho, ang + rho]
    cuts.append(math.pi)
    n_uniform = max(2048, 16 * (d + open_loop_poles.size + 2))
    # An open-loop pole just inside the circle swings arg F by −π within an arc of its distance; a closed-loop
    # pole just outside beside it swings −π too: together −2π, invisible between coarse samples.  So sample
    # geometrically towards every such pole, down to a thousandth of its distance: its swing is then resolved
    # and a closed-loop pole's own swing stands out (and is refined).
    near = []
    for z in open_loop_poles:
        ang, dist = abs(float(np.angle(z))), 1.0 - abs(z)
        if 1e-12 < ang < math.pi and 0.0 < dist < 0.1:
            steps = np.geomspace(max(dist, 1e-300) * 1e-3, 0.2, 300)
            near.append(np.concatenate([ang - steps, ang + steps]))
    near_pts = np.concatenate(near) if near else np.zeros(0)
    evaluated = 0
    segments: list[tuple[np.ndarray, np.ndarray]] = []
    unresolved: list[float] = []
    for a, b in zip(cuts[0::2], cuts[1::2]):
        # uniform for the delay's rotation, logarithmic towards each end for what happens near a pole
        th = np.unique(np.concatenate([np.linspace(a, b, n_uniform), np.geomspace(a, b, 1500),
                                       a + (b - a) * np.geomspace(1e-13, 1.0, 800),
                                       b - (b - a) * np.geomspace(1e-13, 1.0, 800), near_pts]))
        th = th[(th >= a) & (th <= b)]
        vals = ret_diff(th)
        evaluated += th.size
        frozen = np.zeros(0)            # left ends of the intervals double precision cannot refine
        for _ in range(_MAX_ROUNDS):
            step = np.angle(vals[1:] / vals[:-1])
            bad = np.nonzero(np.abs(step) > math.pi / 3)[0]
            bad = bad[~np.isin(th[bad], frozen)]
            if bad.size == 0:
                break
            width = th[bad + 1] - th[bad]
            floor = width <= 8 * np.finfo(float).eps * th[bad + 1]
            if np.any(floor):
                if precise is None:
                    return UnstableCount(None, evaluated, "arg F turns faster than double precision resolves: a "
                                                          "pole lies within rounding of the unit circle")
                frozen = np.concatenate([frozen, th[bad[floor]]])
                unresolved += [float(v) for v in 0.5 * (th[bad[floor]] + th[bad[floor] + 1])]
                bad = bad[~floor]
                if bad.size == 0:
                    break
            mid = 0.5 * (th[bad] + th[bad + 1])
            new = ret_diff(mid)
            evaluated += mid.size
            th = np.insert(th, bad + 1, mid)
            vals = np.insert(vals, bad + 1, new)
        else:
            return UnstableCount(None, evaluated, f"arg F not resolved after {_MAX_ROUNDS} bisections")
        if not np.all(np.isfinite(vals)) or np.any(vals == 0):
            return UnstableCount(None, evaluated, "the return difference vanished or overflowed on the circle")
        segments.append((th, vals))
    total = sum(float(np.sum(np.angle(v[1:] / v[:-1]))) for _, v in segments)
    note = None
    if precise is not None:
        fix = precise_correction(segments, ret_diff, precise, digits, unresolved, open_loop_poles, rounding)
        if fix.reason is not None:
            return UnstableCount(None, evaluated, fix.reason)
        total += fix.turn
        note = fix.note
    wind = (2.0 * total + math.pi * m1 + 2.0 * math.pi * 2 * len(pair_angles) / 2) / (2.0 * math.pi)
    k = round(wind)
    if abs(wind - k) > 0.05:
        return UnstableCount(None, evaluated, f"the winding number {wind:.3f} is not an integer", note)
    return UnstableCount(int(m1 + 2 * len(pair_angles) - k), evaluated, None, note)
