"""The sampled plant G_1(z) of the force-feedforward loop (chapter §5.1, eq. 29-31).

The loop of ARCHITECTURE.md is 1 + K_f·D(z)·G_1(z) = 0 with

    G_1 = Z[H(s)·G_f(s)·Z_h·G_c/(1 + Z_h·G_d)·e^{-t_d s}],

the transfer from the motor force F_m to minus the measured user force -F_s:
the user's force is F_u = F_h - Z_h·x_d (x_d the position of the mass the user
holds), so F_u = (...)·F_h - Z_h·G_c/(1 + Z_h·G_d)·F_m, and the feedforward
pushes F_m = K_f·D·F_s.  Rigid devices have G_c = G_d = G = 1/(ms² + bs); the
cable model (§4) has the user on the body mass m_d and the motor on m_r.

It is built as a continuous state space (device + human attached to the held
mass + the sensor's first-order filter, output -F_s) in dimensionless form
(time in samples, masses in units of m, forces in units of m·[length]/T²) and
discretised exactly by :class:`models.discretize.StateSpaceZOH` with the loop
delay split into whole and fractional samples (no Padé).  G_1 is a force-to-force
ratio, so it needs no m/T² scaling: it is the same number in SI and
dimensionless units, and K_f is dimensionless.

No sensor filter (T_f = 0) on a rigid device: the measured force then has a
direct term from the motor force (F_u = -m_h/(m + m_h)·F_m + ...: the hand's mass
reacts at once).  A sampler reads the force just before the hold updates (kT⁻),
so that term acts through u[k-d-1], i.e. G_1 gets + D·z^{-d-1}.  This is also the
limit T_f → 0⁺ of the filtered model (a first-order filter cannot follow the
jump at kT); Z[·] of a non-strictly-proper transfer would instead pick the
right limit kT⁺ and make the loop algebraic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.device import Device, Human
from models.discretize import StateSpaceZOH, fold_angle, split_delay

__all__ = ["CHAPTER_HUMAN", "FeedforwardPlant", "feedforward_plant", "feedforward_state_space"]

#: The grasp of eq. 30 (Yokokohji & Yoshikawa): Z_h = 2 s² + 2 s + 10.
CHAPTER_HUMAN = Human(mass=2.0, damping=2.0, stiffness=10.0)


def feedforward_state_space(device: Device, human: Human) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(A, B, C, D) of H·Z_h·G_c/(1 + Z_h·G_d)·G_f without the hold, dimensionless.

    Input: motor force; output: minus the measured user force.  D is nonzero only
    for a rigid device without sensor filter.
    """
    m, t = device.mass, device.sample_time
    mu_h, dl_h, ka_h = human.mass / m, human.damping * t / m, human.stiffness * t * t / m
    if device.cable is None:
        a, b, c, dd = _rigid(device.delta, mu_h, dl_h, ka_h)
    else:
        cb = device.cable
        a, b, c, dd = _cable(cb.motor_mass / m, cb.body_mass / m, cb.motor_damping * t / m,
                             cb.body_damping * t / m, cb.stiffness * t * t / m, cb.damping * t / m,
                             mu_h, dl_h, ka_h)
    tau = device.force_sensor.time_constant / t if device.force_sensor is not None else 0.0
    if tau > 0.0:
        # τ ṡ = y_u - s: the sensor state takes the direct term as an input, output s.
        n = a.shape[0]
        a2 = np.zeros((n + 1, n + 1))
        a2[:n, :n] = a
        a2[n, :n] = c / tau
        a2[n, n] = -1.0 / tau
        b2 = np.append(b, dd / tau)
        c2 = np.zeros(n + 1)
        c2[n] = 1.0
        return a2, b2, c2, 0.0
    return a, b, c, dd


def _rigid(delta: float, mu_h: float, dl_h: float, ka_h: float):
    # (1 + μ_h) v̇ = u - (δ + δ_h) v - κ_h x;  -F_u = μ_h v̇ + δ_h v + κ_h x.
    mt = 1.0 + mu_h
    c_v, c_u = (dl_h - mu_h * delta) / mt, mu_h / mt
    if ka_h == 0.0:
        # Without a grasp stiffness the position is unobservable: leave it out so
        # the realisation is minimal (no spurious closed-loop pole fixed at z = 1).
        return np.array([[-(delta + dl_h) / mt]]), np.array([1.0 / mt]), np.array([c_v]), c_u
    a = np.array([[0.0, 1.0], [-ka_h / mt, -(delta + dl_h) / mt]])
    return a, np.array([0.0, 1.0 / mt]), np.array([ka_h / mt, c_v]), c_u


def _cable(mu_r, mu_d, dl_r, dl_d, ka_c, dl_c, mu_h, dl_h, ka_h):
    # States [x_d, e = x_r - x_d, v_r, v_d]; the user (and the hand's mass) on the body mass.
    #   μ_r v̇_r = u - δ_r v_r - κ_c e - δ_c (v_r - v_d)
    #   (μ_d + μ_h) v̇_d = -(δ_d + δ_h) v_d - κ_h x_d + κ_c e + δ_c (v_r - v_d)
    #   -F_u = μ_h v̇_d + δ_h v_d + κ_h x_d
    # The cable stretch e is a state of its own so that, without a grasp stiffness, the
    # common position x_d (unobservable then) can be left out: the realisation stays
    # minimal and no eigenvalue sits at rounding level near 0 (z = 1).
    md = mu_d + mu_h
    a = np.zeros((4, 4))
    a[0, 3] = 1.0
    a[1, 2], a[1, 3] = 1.0, -1.0
    a[2] = [0.0, -ka_c / mu_r, -(dl_r + dl_c) / mu_r, dl_c / mu_r]
    a[3] = [-ka_h / md, ka_c / md, dl_c / md, -(dl_d + dl_h + dl_c) / md]
    b = np.array([0.0, 0.0, 1.0 / mu_r, 0.0])
    c = mu_h * a[3] + np.array([ka_h, 0.0, 0.0, dl_h])
    if ka_h == 0.0:
        return a[1:, 1:], b[1:], c[1:], 0.0
    return a, b, c, 0.0


@dataclass(frozen=True)
class FeedforwardPlant:
    """G_1(e^{jθ}) of eq. 29, exactly sampled, with its matrices for closed-loop checks."""

    zoh: StateSpaceZOH
    direct: float
    """D: direct term of the continuous plant, acting through u[k-d-1] (see module doc)."""
    theta_min: float
    """Lowest angle [rad/sample] worth scanning: G_1 is flat and nearly real below it."""
    hints: tuple[float, ...]
    """Angles [rad/sample] of lightly damped poles and zeros (dense scan around them)."""
    width_hint: float
    """Smallest |Re λ| of a lightly damped pole or zero [1/sample], the width of its peak."""

    @property
    def d(self) -> int:
        return self.zoh.d

    @property
    def f(self) -> float:
        return self.zoh.f

    def response(self, theta: np.ndarray) -> np.ndarray:
        """G_1(e^{jθ}) (dimensionless force ratio)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        g = self.zoh.response(theta)
        if self.direct != 0.0:
            g = g + self.direct * np.exp(-1j * (self.zoh.d + 1) * theta)
        return g

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(Φ, Γ0, Γ1, C): x[k+1] = Φx + Γ0 u[k-d] + Γ1 u[k-d-1], y[k] = Cx[k] + D u[k-d-1]."""
        return self.zoh.matrices()


def feedforward_plant(device: Device, human: Human) -> FeedforwardPlant:
    """The sampled G_1 of ``device`` held by ``human`` (sensor filter from ``device.force_sensor``)."""
    a, b, c, dd = feedforward_state_space(device, human)
    d, f = split_delay(device.delay_samples)
    t, m = device.sample_time, device.mass
    zeros = np.roots([human.mass / m, human.damping * t / m, human.stiffness * t * t / m])
    zoh = StateSpaceZOH(a=a, b=b, c=c, d=d, f=f, zeros_hint=tuple(float(abs(z.imag)) for z in zeros))
    lam = np.linalg.eigvals(a)
    rates = [abs(v) for v in lam if abs(v) > 1e-12 * np.max(np.abs(lam))] + [abs(z) for z in zeros if abs(z) > 0]
    rates.append(1.0 / (d + f + 1.0))
    theta_min = min(1e-2, max(1e-9, 1e-2 * min(rates)))
    # Dense scans only around lightly damped poles and zeros (ζ < 0.2, e.g. the cable
    # mode): a well-damped grasp turns the phase slowly and the adaptive bisection of
    # optim/stability/crossovers.py resolves it; every extra cluster costs ~320 evaluations.
    light = [v for v in list(lam) + list(zeros) if abs(v.imag) > 0 and -v.real < 0.2 * abs(v)]
    hints = tuple(sorted({fold_angle(abs(v.imag)) for v in light}))
    width = min((abs(v.real) for v in light), default=0.0)
    return FeedforwardPlant(zoh=zoh, direct=float(dd), theta_min=theta_min, hints=hints,
                            width_hint=width)

