"""The sampled loop of a scene: controller, delay line, and its two exact propagations.

Sample k (time kT): the encoder reads the motor position, the controller computes
the command u[k]; the motor applies u[k-d-1] during the first f of the period and
u[k-d] during the rest (t_d = (d + f)T).  Controllers:

  * wall: u = -K·y - B·(y - y_prev)/T + K_f·D(z)[s]  (C(z) of ARCHITECTURE.md, §5 feedforward)
  * relay: u = -h·sign(y)   (Åström–Hägglund; sign(0) keeps the last command)

y is the measured position (q·round(x/q) with quantization), u is clipped to
±max_force with saturation.  Before t = 0 the motor applied no force, and the
wall's velocity estimate starts as if the device had moved at its initial velocity.

Two propagations, both exact between samples:
  * ``closed_loop_matrices`` writes a linear scene as one recursion for
    models/simulation/propagate.py (no Python loop over samples);
  * ``run_sampled_loop`` steps sample by sample, for sampled nonlinearities
    (relay, quantization, saturation) and for a continuous-time plant stepper
    (Coulomb friction, models/simulation/friction.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import butter, tf2ss

from models.errors import InputError
from models.simulation.sim_plant import SampledPlant

__all__ = ["LoopSpec", "Record", "feedforward_filter", "closed_loop_matrices", "run_sampled_loop",
           "linear_step", "wall_polynomials", "linear_part"]


@dataclass(frozen=True)
class LoopSpec:
    sampled: SampledPlant
    stiffness: float = 0.0
    damping: float = 0.0
    relay_amplitude: float | None = None
    ff_gain: float = 0.0
    ff_filter: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
    """D(z) as (A_d, B_d, C_d, D_d); None with ff_gain > 0 means D = 1."""
    quantization: float | None = None
    max_force: float | None = None
    wall: tuple[np.ndarray, np.ndarray] | None = None
    """A rendered wall's difference equation D(z⁻¹)·w = −P(z⁻¹)·y (P, D ascending in z⁻¹, D[0] = 1; SI): a velocity
    filter or a virtual mass (:func:`wall_polynomials`); None: today's u = −K·y − B·(y − y_prev)/T."""


def wall_polynomials(stiffness: float, damping: float, mass: float, velocity, sample_time: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(P, D) of C = K + B·V + M·A with V = (1 − z⁻¹)·R/(T·D) (models.velocity_filter.VelocityTransfer ``velocity``):
    D·C = K·D + (B/T)·N̂ + (M/T²)·N̂·(1 − z⁻¹), N̂ = (1 − z⁻¹)·R."""
    t = sample_time
    den = np.asarray(velocity.d, dtype=float)
    nhat = np.convolve([1.0, -1.0], velocity.r)
    p = np.zeros(max(den.size, nhat.size + 1))
    p[:den.size] += stiffness * den
    p[:nhat.size] += damping / t * nhat
    p[:nhat.size + 1] += mass / (t * t) * np.convolve(nhat, [1.0, -1.0])
    return p, den


def linear_part(spec: LoopSpec) -> LoopSpec:
    """The scene's loop without its sampled nonlinearities (quantization, saturation)."""
    return replace(spec, quantization=None, max_force=None, relay_amplitude=None)


@dataclass(frozen=True)
class Record:
    """Per-sample record of a run: positions at k = 0..n, forces and mid-sample position for k < n."""

    motor_position: np.ndarray
    body_position: np.ndarray
    command: np.ndarray
    applied_first: np.ndarray
    """u[k-d-1], held during [kT, kT + fT)."""
    applied_second: np.ndarray
    """u[k-d], held during [kT + fT, (k+1)T)."""
    motor_position_mid: np.ndarray
    """x_r(kT + fT)."""

    def truncated(self, n: int) -> "Record":
        return Record(self.motor_position[:n + 1], self.body_position[:n + 1], self.command[:n],
                      self.applied_first[:n], self.applied_second[:n], self.motor_position_mid[:n])


def feedforward_filter(cutoff_hz: float | None, order: int, sample_time: float):
    """D(z): Butterworth low-pass, bilinear transform prewarped at its cutoff (scipy.signal.butter, fs given)."""
    if cutoff_hz is None:
        return None
    fs = 1.0 / sample_time
    if not cutoff_hz < fs / 2:
        raise InputError("scene.effects.force_feedforward.cutoff_hz", f"must be below the Nyquist frequency "
                         f"{fs / 2:g} Hz")
    # A cascade of second-order sections, not one companion form: at a low cutoff the poles cluster near
    # z = 1 and a companion matrix's eigenvalues (and its powers) lose ~all digits (a 1.24 Hz 4th-order
    # filter at 5 kHz put a pole at |z| = 1.00002 where the exact one is 0.99996, and the run diverged).
    sections = butter(order, cutoff_hz, btype="low", output="sos", fs=fs)
    a, b, c, d = np.zeros((0, 0)), np.zeros(0), np.zeros(0), 1.0
    for sec in sections:
        a2, b2, c2, d2 = tf2ss(sec[:3], sec[3:])
        b2, c2, d2 = b2[:, 0], c2[0], float(d2[0, 0])
        n, m = a.shape[0], a2.shape[0]
        big = np.zeros((n + m, n + m))      # this section is driven by the output of the ones before
        big[:n, :n], big[n:, n:] = a, a2
        big[n:, :n] = np.outer(b2, c)
        a, b, c, d = big, np.concatenate([b, b2 * d]), np.concatenate([d2 * c, c2]), d2 * d
    return a, b, c, d


def _sizes(spec: LoopSpec) -> tuple[int, int, int]:
    n = spec.sampled.phi.shape[0]
    nd = 0 if spec.ff_filter is None else spec.ff_filter[0].shape[0]
    return n, spec.sampled.d + 1, nd


def closed_loop_matrices(spec: LoopSpec, x0: np.ndarray, v0: float):
    """(A_cl, b_w, out, d_out, ζ0) of a linear wall scene; outputs as in :class:`Record` order.

    ζ = [x (n), u[k-1] … u[k-d-1], y[k-1], D(z) states, and a rendered wall's y[k-2] … and w[k-1] …].
    """
    if spec.relay_amplitude is not None or spec.quantization is not None or spec.max_force is not None:
        raise ValueError("closed_loop_matrices: only a linear scene has closed-loop matrices")
    sp, pl = spec.sampled, spec.sampled.plant
    n, nb, nd = _sizes(spec)
    d, t = sp.d, sp.sample_time
    # a rendered wall adds its past positions y[k−2] … and its past outputs w[k−1] … after the feedforward states
    ny, nw = (0, 0) if spec.wall is None else (max(spec.wall[0].size - 2, 0), spec.wall[1].size - 1)
    iy2, iw = n + nb + 1 + nd, n + nb + 1 + nd + ny
    size = n + nb + 1 + nd + ny + nw
    ip = pl.motor_position
    lrow = np.zeros(size)                       # u[k] = lrow · ζ[k]
    if spec.wall is None:
        lrow[ip] -= spec.stiffness + spec.damping / t
        lrow[n + nb] += spec.damping / t
    else:
        p, den = spec.wall
        lrow[ip] -= p[0]
        if p.size > 1:
            lrow[n + nb] -= p[1]
        for i in range(2, p.size):
            lrow[iy2 + i - 2] -= p[i]
        for i in range(1, den.size):
            lrow[iw + i - 1] -= den[i]
    wrow = lrow.copy()                          # the wall's own output, before the feedforward
    if spec.ff_gain:
        if pl.sensor is None:
            raise InputError("scene.effects.force_feedforward", "needs the force sensor state")
        if spec.ff_filter is None:
            lrow[pl.sensor] += spec.ff_gain
        else:
            ad, bd, cd, dd = spec.ff_filter
            lrow[pl.sensor] += spec.ff_gain * dd
            lrow[n + nb + 1:n + nb + 1 + nd] += spec.ff_gain * cd
    ub_row = lrow if d == 0 else np.eye(size)[n + d - 1]
    ua_row = np.eye(size)[n + d]
    a = np.zeros((size, size))
    a[:n, :n] = sp.phi
    a[:n] += np.outer(sp.gamma0, ub_row) + np.outer(sp.gamma1, ua_row)
    a[n] = lrow
    for j in range(1, nb):
        a[n + j, n + j - 1] = 1.0
    a[n + nb, ip] = 1.0
    if spec.ff_filter is not None:                # nd > 0
        ad, bd, cd, dd = spec.ff_filter
        a[n + nb + 1:n + nb + 1 + nd, n + nb + 1:n + nb + 1 + nd] = ad
        a[n + nb + 1:n + nb + 1 + nd, pl.sensor] = bd
    for j in range(ny):                          # y[k−2−j] ← y[k−1−j]
        a[iy2 + j, n + nb if j == 0 else iy2 + j - 1] = 1.0
    for j in range(nw):                          # w[k−1−j] ← w[k−j]
        if j == 0:
            a[iw] = wrow
        else:
            a[iw + j, iw + j - 1] = 1.0
    b_w = np.zeros(size)
    b_w[:n] = sp.gamma_user
    out = np.zeros((6, size))
    out[0, ip] = 1.0
    out[1, pl.body_position] = 1.0
    out[2] = lrow
    out[3] = ua_row
    out[4] = ub_row
    out[5, :n] = sp.mid_phi[ip]
    out[5] += sp.mid_motor[ip] * ua_row
    d_out = np.array([0, 0, 0, 0, 0, sp.mid_user[ip]], dtype=float)
    z0 = np.zeros(size)
    z0[:n] = x0
    z0[n + nb] = x0[ip] - v0 * t
    for j in range(ny):
        z0[iy2 + j] = x0[ip] - v0 * t * (j + 2)
    for j in range(nw):
        # the wall's past outputs as if the device had moved at v0 (a velocity estimate of a ramp is v0)
        z0[iw + j] = -spec.stiffness * (x0[ip] - v0 * t * (j + 1)) - spec.damping * v0
    return a, b_w, out, d_out, z0


Stepper = Callable[[np.ndarray, float, float, float], tuple[np.ndarray, float]]


def linear_step(sp: SampledPlant) -> Stepper:
    """Exact one-sample step of the linear plant: (x, u_first, u_second, w) → (x[k+1], x_r(kT + fT))."""
    phi, g0, g1, gu = sp.phi, sp.gamma0, sp.gamma1, sp.gamma_user
    mrow, mm, mu = sp.mid_phi[sp.plant.motor_position], sp.mid_motor[sp.plant.motor_position], \
        sp.mid_user[sp.plant.motor_position]

    def step(x: np.ndarray, ua: float, ub: float, w: float) -> tuple[np.ndarray, float]:
        mid = float(mrow @ x) + mm * ua + mu * w
        return phi @ x + g0 * ub + g1 * ua + gu * w, mid
    return step


def run_sampled_loop(spec: LoopSpec, x0: np.ndarray, v0: float, w: np.ndarray, n_samples: int,
                     step: Stepper, diverge_at: float = np.inf) -> tuple[Record, int]:
    """Step the loop n_samples times; stops early when |x_r| exceeds ``diverge_at``.

    Returns the record and the number of samples actually run.
    """
    pl, t, d = spec.sampled.plant, spec.sampled.sample_time, spec.sampled.d
    ip, ib = pl.motor_position, pl.body_position
    xr = np.zeros(n_samples + 1)
    xb = np.zeros(n_samples + 1)
    cmd = np.zeros(n_samples)
    ua_rec = np.zeros(n_samples)
    ub_rec = np.zeros(n_samples)
    mid = np.zeros(n_samples)
    q, fmax, relay = spec.quantization, spec.max_force, spec.relay_amplitude
    k_wall, b_wall, kf = spec.stiffness, spec.damping / t, spec.ff_gain
    ff = spec.ff_filter
    xd = np.zeros(0 if ff is None else ff[0].shape[0])
    buf = [0.0] * (d + 1)                       # buf[j] = u[k-1-j]
    x = np.array(x0, dtype=float)

    def measure(pos: float) -> float:
        return q * round(pos / q) if q is not None else pos

    y_prev = measure(x[ip] - v0 * t)
    if spec.wall is not None:
        p_wall, d_wall = spec.wall
        ys = [measure(x[ip] - v0 * t * j) for j in range(1, p_wall.size)]      # y[k−1], y[k−2], …
        ws = [-k_wall * (x[ip] - v0 * t * j) - spec.damping * v0 for j in range(1, d_wall.size)]
    last = relay if relay is not None else 0.0
    if relay is not None:
        last = -relay if x[ip] > 0 else relay
    run = n_samples
    for k in range(n_samples):
        xr[k], xb[k] = x[ip], x[ib]
        if not abs(x[ip]) <= diverge_at:
            run = k
            break
        y = measure(x[ip])
        if relay is not None:
            u = -relay if y > 0 else (relay if y < 0 else last)
        else:
            if spec.wall is None:
                u = -k_wall * y - b_wall * (y - y_prev)
            else:
                u = -p_wall[0] * y - sum(p_wall[i] * ys[i - 1] for i in range(1, p_wall.size)) \
                    - sum(d_wall[i] * ws[i - 1] for i in range(1, d_wall.size))
                ys = [y] + ys[:-1] if ys else ys
                ws = [u] + ws[:-1] if ws else ws
            if kf:
                s = x[pl.sensor]
                if ff is None:
                    u += kf * s
                else:
                    u += kf * (float(ff[2] @ xd) + ff[3] * s)
                    xd = ff[0] @ xd + ff[1] * s
        if fmax is not None:
            u = min(max(u, -fmax), fmax)
        y_prev, last = y, u
        ua = buf[d]
        ub = u if d == 0 else buf[d - 1]
        cmd[k], ua_rec[k], ub_rec[k] = u, ua, ub
        x, mid[k] = step(x, ua, ub, float(w[k]))
        buf = [u] + buf[:-1]
    else:
        xr[n_samples], xb[n_samples] = x[ip], x[ib]
    rec = Record(xr, xb, cmd, ua_rec, ub_rec, mid)
    return (rec.truncated(run) if run < n_samples else rec), run
