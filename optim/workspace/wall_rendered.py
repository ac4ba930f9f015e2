"""The rendered wall C(z) = K + B·V(z) + M·A(z) on a multi-DOF device's SISO plant at one pose and normal, exactly.

The plant along n is optim.workspace.wall_plant's G_n = Σ c_i/(s(s + λ_i)) (every mode's exact ZOH with the delay,
summed).  The rendered loop is optim.stability.rendered's argument with this G_n in place of a 1-DOF device's
(dimensionless with the effective mass m_e: α = KT²/m_e, β = BT/m_e, μ = M/m_e):

    K:  h_K(θ) = −1/G_n − β V_n − μ A_n          (K_cr: the smallest positive real value of h_K)
    B:  h_B(θ) = (−1/G_n − μ A_n)/V_n            (B_max at this M)
    M:  h_M(θ) = (−1/G_n − β V_n)/A_n            (the virtual mass at α = 0⁺)

K_cr is the smallest positive crossover once the K = 0⁺ loop (every pole but z = 1) is stable.  That loop is decided by
counting unstable poles along one path from (B, M) = (0, 0), where it is stable when every mode seen is damped
(λ_i > 0: G_n has one pole at z = 1, the others at e^{−λ_i T}, the filter's inside): B from 0 at M = 0 across the real
values of h_B, then M from 0 at B across those of h_M, each crossing's direction from the sign of d Im h/dθ
(optim.stability.rendered.real_crossings).  A mode with λ_i = 0 (an undamped joint seen along n), or a crossing whose
direction is not resolved, is refused with the field named: never guessed.
"""

from __future__ import annotations

import math

import numpy as np

from models.discretize import RigidZOH, split_delay
from models.velocity_filter import Rendering
from optim.errors import InputError
from optim.stability.crossovers import positive_real_crossings, scan_grid, theta_min
from optim.stability.rendered import Passage, loop_poles, real_crossings, velocity_response
from optim.stability.rendered_rigid import v_zero_at_pi

from .wall_plant import WallCritical, WallModes

__all__ = ["RenderedWall"]

_TINY = 1e-300


def _walk(passages: list[Passage], end: float, unstable: int | None) -> int | None:
    """Unstable poles after moving a gain from 0 to ``end`` ≥ 0 across ``passages`` (None: not resolved)."""
    if unstable is None or end == 0.0:
        return unstable
    for c in sorted(passages, key=lambda c: c.value):
        if 0.0 < c.value <= end:
            if c.outward == 0:
                return None
            unstable += c.outward
    return unstable if unstable >= 0 else None


class RenderedWall:
    """The rendered wall's loop on G_n at one pose and normal (module doc): B_max and K_cr(B)."""

    def __init__(self, modes: WallModes, sample_time: float, delay: float, rendering: Rendering,
                 field: str = "requirements.workspace.kinematics.joint_damping") -> None:
        if any(li == 0.0 for li in modes.lam):
            raise InputError(field, "a velocity filter or a virtual mass on a workspace needs every joint damped "
                                    "(an undamped joint seen along the normal leaves a double pole at z = 1 that "
                                    "this analysis does not resolve)")
        self.t = sample_time
        self.m = modes.effective_mass
        self.rendering = rendering
        self.mu = rendering.mass / self.m
        d_samples = delay / sample_time
        d, f = split_delay(d_samples)
        self.plants = [(ci * self.m, RigidZOH(li * sample_time, d, f)) for ci, li in zip(modes.c, modes.lam)]
        deltas = [li * sample_time for li in modes.lam]
        low = sample_time / (self.m * math.fsum(ci / li for ci, li in zip(modes.c, modes.lam)))
        self._damp = min([low] + deltas)
        self._d = d_samples
        self._width = max(min(deltas), 1e-6)
        vel = rendering.velocity
        self._hints = tuple(vel.pole_angles()) + tuple(vel.zero_angles())
        self._damper: list[Passage] | None = None
        self._b_max: float | None = None

    def _grid(self, beta: float) -> np.ndarray:
        return scan_grid(theta_min(float(self._damp + beta), float(self._d)), self._d, self._hints,
                         width_hint=self._width)

    def _inv(self, theta: np.ndarray) -> np.ndarray:
        return np.asarray(-1.0 / sum(w * p.response(theta) for w, p in self.plants))

    def _damper_passages(self, mu: float = 0.0) -> list[Passage]:
        """β values where the K = 0⁺ loop at μ gets a pole on the circle (kept for μ = 0)."""
        if mu == 0.0 and self._damper is not None:
            return self._damper
        vel = self.rendering.velocity

        def h(theta: np.ndarray) -> np.ndarray:
            v = velocity_response(vel, theta)
            with np.errstate(over="ignore", divide="ignore"):
                return (self._inv(theta) - mu * v * -np.expm1(-1j * theta)) / np.where(np.abs(v) < _TINY, _TINY, v)
        found = real_crossings(h, self._grid(0.0), v_zero_at_pi(vel), loop_poles(vel))
        if mu == 0.0:
            self._damper = found
        return found

    def _signed_mass_walk(self, beta: float, n: int | None) -> int | None:
        if self.mu == 0.0 or n is None:
            return n
        ps = self._mass_passages(beta)
        if self.mu > 0:
            return _walk(ps, self.mu, n)
        return _walk([Passage(c.angle, -c.value, c.outward) for c in ps], -self.mu, n)

    def _mass_passages(self, beta: float) -> list[Passage]:
        """μ values (signed) where the K = 0⁺ loop at β gets a pole on the circle."""
        vel = self.rendering.velocity

        def h(theta: np.ndarray) -> np.ndarray:
            v = velocity_response(vel, theta)
            a = v * -np.expm1(-1j * theta)
            with np.errstate(over="ignore", divide="ignore"):
                return (self._inv(theta) - beta * v) / np.where(np.abs(a) < _TINY, _TINY, a)
        return real_crossings(h, self._grid(beta), v_zero_at_pi(vel), loop_poles(vel))

    def _reduced(self, beta: float) -> int:
        """Unstable poles of the K = 0⁺ loop at (β, μ) (InputError when the count is not resolved)."""
        n = self._signed_mass_walk(beta, _walk(self._damper_passages(), beta, 0))
        if n is None:
            raise InputError("controller.mass" if self.mu else "controller.velocity_filter",
                             "whether the workspace wall with K → 0⁺ is stable at this pose and normal cannot be "
                             "decided (a crossing whose direction is not resolved)")
        return n

    def max_stable_damping(self) -> float:
        """B_max [N·s/m] at this M: M from 0 at B = 0, then B from 0 across h_B's real values (as
        optim.stability.rendered.rendered_max_stable_damping); inf when no B destabilises the K = 0⁺ loop, 0 when
        it is unstable already, nan when a count is not resolved."""
        if self._b_max is None:
            n0 = self._signed_mass_walk(0.0, 0)
            if n0 is None:
                self._b_max = math.nan
                return self._b_max
            n, last, bad = n0, 0.0, False
            for c in sorted((c for c in self._damper_passages(self.mu) if c.value > 0.0), key=lambda c: c.value):
                if c.outward == 0:
                    bad = True
                    break
                before, n = n, n + c.outward
                if before == 0 and n > 0:
                    last = c.value
                elif n < 0:
                    bad = True
                    break
            self._b_max = math.nan if bad else math.inf if n == 0 else last * self.m / self.t
        return self._b_max

    def critical(self, damping: float) -> WallCritical:
        """K_cr(B) [N/m] of the rendered wall along n, its crossover frequency [rad/s] and every crossover."""
        beta = damping * self.t / self.m
        if self._reduced(beta) > 0:
            return WallCritical(0.0, None, (), f"with B = {damping:.6g} N·s/m and this velocity filter and virtual "
                                               "mass the loop is unstable already as K → 0⁺")
        rend, mu = self.rendering, self.mu

        def h(theta: np.ndarray) -> np.ndarray:
            return self._inv(theta) - rend.controller_response(theta, beta, mu)
        found = positive_real_crossings(h, self._grid(beta))
        scale = self.m / self.t ** 2
        crossovers = tuple((c.angle / self.t, c.value * scale) for c in found)
        if not crossovers:
            return WallCritical(math.inf, None, (), "no phase crossover: every positive stiffness is stable")
        best = min(crossovers, key=lambda c: c[1])
        return WallCritical(best[1], best[0], crossovers)
