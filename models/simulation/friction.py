"""Coulomb friction on the motor-side mass: an exact piecewise-affine integrator with event location.

Between events the plant is linear with constant inputs (the held motor force,
the held user force, and the friction force -c·sign(v) of the current mode), so
each piece is propagated exactly by one augmented matrix exponential.  Modes:

  * slip (+1/-1): friction force -c·sign(v) on the motor-side mass;
  * stick (0): that mass's velocity row is frozen at 0; it breaks away when the
    net force on it without friction, F_net = m_f·(A x + b u)[v], exceeds c.

Events (v crossing 0 in slip; |F_net| reaching c in stick) are detected on
sub-steps of at most T/8 and located by Brent's method on the exact solution,
so an event is missed only if the sign changes twice within T/8 (a motion with
a period below T/4, far above the Nyquist frequency of the loop).  A step with
more than MAX_EVENTS_PER_SAMPLE events raises rather than returning a guess.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq

from models.simulation.sim_plant import SampledPlant, exp_affine

__all__ = ["FrictionStepper", "FrictionEventLimit", "MAX_EVENTS_PER_SAMPLE", "SUBSTEPS"]

MAX_EVENTS_PER_SAMPLE = 50
SUBSTEPS = 8


class FrictionEventLimit(RuntimeError):
    """More than MAX_EVENTS_PER_SAMPLE stick-slip events in one piece of a sample (a Zeno-like chatter the
    integrator refuses to guess through)."""


class FrictionStepper:
    """Callable (x, u_first, u_second, w) → (x[k+1], x_r(kT + fT)) with Coulomb friction c [N]."""

    def __init__(self, sampled: SampledPlant, friction: float) -> None:
        pl = sampled.plant
        self.t, self.f, self.c = sampled.sample_time, sampled.f, friction
        self.iv, self.ip = pl.motor_velocity, pl.motor_position
        n = pl.a.shape[0]
        self.m_f = pl.motor_side_mass
        bf = np.zeros(n)
        bf[self.iv] = 1.0 / self.m_f
        self.a_slip = pl.a
        self.inputs_slip = np.column_stack([pl.b_motor, pl.b_user, bf])
        self.a_stick = pl.a.copy()
        self.a_stick[self.iv] = 0.0
        self.inputs_stick = self.inputs_slip.copy()
        self.inputs_stick[self.iv] = 0.0
        self.net_row = self.m_f * pl.a[self.iv]
        self.net_in = self.m_f * np.array([pl.b_motor[self.iv], pl.b_user[self.iv]])
        self.mode = 0
        self._cache: dict[tuple[int, float], tuple[np.ndarray, np.ndarray]] = {}
        self.events = 0

    def reset(self, x0: np.ndarray) -> None:
        v = x0[self.iv]
        self.mode = 0 if v == 0.0 else (1 if v > 0 else -1)
        self.events = 0

    def _mats(self, mode: int, h: float) -> tuple[np.ndarray, np.ndarray]:
        key = (mode, h)
        if key not in self._cache:
            if len(self._cache) > 64:
                self._cache.clear()
            a, ins = (self.a_stick, self.inputs_stick) if mode == 0 else (self.a_slip, self.inputs_slip)
            self._cache[key] = exp_affine(a, ins, h)
        return self._cache[key]

    def _net(self, x: np.ndarray, fm: float, fh: float) -> float:
        return float(self.net_row @ x) + self.net_in[0] * fm + self.net_in[1] * fh

    def _decide(self, x: np.ndarray, fm: float, fh: float) -> int:
        net = self._net(x, fm, fh)
        return 0 if abs(net) <= self.c else (1 if net > 0 else -1)

    def _advance(self, x: np.ndarray, fm: float, fh: float, tau: float) -> np.ndarray:
        """Propagate over tau seconds with constant forces, handling every mode change."""
        remaining = tau
        events_here = 0
        h_max = self.t / SUBSTEPS
        if self.mode == 0 or x[self.iv] == 0.0:
            self.mode = self._decide(x, fm, fh)
            if self.mode == 0:
                x = x.copy()
                x[self.iv] = 0.0
        while remaining > 0.0:
            m_sub = max(1, math.ceil(remaining / h_max - 1e-9))
            h = remaining / m_sub
            mode = self.mode
            p = np.array([fm, fh, -mode * self.c])
            e, g = self._mats(mode, h)
            hit = False
            for _ in range(m_sub):
                x_new = e @ x + g @ p
                fun: Callable[[float], float]    # called only in this pass: x, p are this step's
                if mode != 0:
                    crossed = mode * x_new[self.iv] < 0.0
                    fun = (lambda s: self._state(mode, x, p, s)[self.iv])
                else:
                    crossed = abs(self._net(x_new, fm, fh)) > self.c
                    fun = (lambda s: abs(self._net(self._state(0, x, p, s), fm, fh)) - self.c)
                if crossed:
                    lo = fun(0.0)
                    s_ev = 0.0 if lo == 0.0 or (mode != 0 and mode * lo < 0) else \
                        brentq(fun, 0.0, h, xtol=1e-15 * self.t, rtol=4 * np.finfo(float).eps)
                    x = self._state(mode, x, p, s_ev) if s_ev > 0.0 else x.copy()
                    remaining -= s_ev
                    if mode != 0:
                        x[self.iv] = 0.0
                    self.mode = self._decide(x, fm, fh)
                    if mode == 0 and self.mode == 0:
                        # |F_net| touches c exactly at the start: leave in the direction it grows
                        self.mode = 1 if self._net(x_new, fm, fh) > 0 else -1
                    if self.mode == 0:
                        x[self.iv] = 0.0
                    events_here += 1
                    self.events += 1
                    if events_here > MAX_EVENTS_PER_SAMPLE:
                        raise FrictionEventLimit("coulomb_friction: more than "
                                           f"{MAX_EVENTS_PER_SAMPLE} stick-slip events in one piece of a sample")
                    hit = True
                    break
                x = x_new
                remaining -= h
            if not hit:
                remaining = 0.0
        return x

    def _state(self, mode: int, x: np.ndarray, p: np.ndarray, s: float) -> np.ndarray:
        a, ins = (self.a_stick, self.inputs_stick) if mode == 0 else (self.a_slip, self.inputs_slip)
        e, g = exp_affine(a, ins, s)
        return e @ x + g @ p

    def __call__(self, x: np.ndarray, ua: float, ub: float, w: float) -> tuple[np.ndarray, float]:
        if self.f > 0.0:
            x = self._advance(x, ua, w, self.f * self.t)
            mid = float(x[self.ip])
        else:
            mid = float(x[self.ip])
        x = self._advance(x, ub, w, (1.0 - self.f) * self.t)
        return x, mid
