"""Closed loop of the force feedforward (chapter §5), assembled independently of the K_f,cr scan.

The continuous plant from motor force to minus the measured user force is models.feedforward's state space
(the physics: device, grasp, sensor filter); everything after it is separate from optim.transparency.feedforward: the
sampling (optim.stability.closed_loop.discretise, one augmented exponential), the filter D(z) from
scipy.signal.butter's zeros, poles and gain (not the closed form the scan evaluates), the shift register of
delayed forces, and the loop u = −K_f·D·y closed as a state matrix (or its return difference on the circle).
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
from scipy import signal

from models.device import Device, Human
from models.feedforward import feedforward_state_space
from optim.stability.closed_loop import (
    SampledPlant,
    UnstableCount,
    add_delay_chain,
    add_plant_rows,
    count_outside,
    discretise,
)
from optim.stability.closed_loop_mp import PRECISE_DIGITS, MpSampled, mp_sampled, mp_sampled_response

__all__ = ["FeedforwardLoop", "feedforward_closed_loop", "feedforward_loop", "feedforward_unstable_count",
           "precise_return_difference"]


class FeedforwardLoop:
    """The sampled G_1 (with its direct term acting through u[k−d−1]) and the filter's state space; ``continuous``
    = (A, B, C, D, delay [s], T [s]): what the mpmath twin of the plant is sampled from (:meth:`precise_plant`)."""

    def __init__(self, plant: SampledPlant, direct: float, order: int | None, cutoff_hz: float | None,
                 sample_time: float, continuous: tuple | None = None):
        self.plant, self.direct = plant, direct
        self.continuous = continuous
        self._precise: dict[int, MpSampled] = {}
        if order is None:
            self.zpk = (np.zeros(0), np.zeros(0), 1.0)
            self.ss = (np.zeros((0, 0)), np.zeros(0), np.zeros(0), 1.0)
        else:
            z, p, k = signal.butter(order, cutoff_hz, btype="low", output="zpk", fs=1.0 / sample_time)
            self.zpk = (np.asarray(z), np.asarray(p), float(k))
            a, b, c, d = signal.zpk2ss(z, p, k)
            self.ss = (np.asarray(a, float), np.asarray(b, float).ravel(), np.asarray(c, float).ravel(),
                       float(np.squeeze(d)))

    def precise_plant(self, digits: int) -> MpSampled | None:
        """G_1 sampled again in ``digits``-digit mpmath (optim.stability.closed_loop_mp.mp_sampled), built once."""
        if self.continuous is None:
            return None
        if digits not in self._precise:
            a, b, c, dd, delay, t = self.continuous
            self._precise[digits] = mp_sampled(a, b, c, dd, delay, t, digits)
        return self._precise[digits]

    @property
    def states(self) -> int:
        p = self.plant
        return p.e.shape[0] + self.ss[0].shape[0] + self.chain

    @property
    def chain(self) -> int:
        p = self.plant
        return p.d + 1 if (p.f > 0.0 or self.direct != 0.0) else p.d


def feedforward_loop(device: Device, human: Human, order: int | None = None,
                     cutoff_hz: float | None = None) -> FeedforwardLoop:
    a, b, c, dd = feedforward_state_space(device, human)
    return FeedforwardLoop(discretise(a, b, c, device.delay / device.sample_time), float(dd), order, cutoff_hz,
                           device.sample_time, (a, b, c, float(dd), device.delay, device.sample_time))


def feedforward_closed_loop(loop: FeedforwardLoop, force_gain: float) -> np.ndarray:
    """Q = M − I with s = [x, w (filter), u[k−1], …, u[k−L]]; y = c·x + D·u[k−d−1], u = −K_f·(c_f w + d_f y)."""
    p = loop.plant
    af, bf, cf, df = loop.ss
    n, nf, chain, d = p.e.shape[0], af.shape[0], loop.chain, p.d
    size = n + nf + chain
    iw, iu = n, n + nf
    y = np.zeros(size)
    y[:n] = p.c
    if loop.direct != 0.0:
        y[iu + d] += loop.direct
    u = np.zeros(size)
    u[iw:iw + nf] = -force_gain * cf
    u += -force_gain * df * y
    q = np.zeros((size, size))
    add_plant_rows(q, p, u, iu)
    if nf:
        q[iw:iw + nf, iw:iw + nf] = af - np.eye(nf)
        q[iw:iw + nf, :] += np.outer(bf, y)
    add_delay_chain(q, u, iu, chain)
    return q


def _return_difference(loop: FeedforwardLoop, force_gain: float, theta: np.ndarray) -> np.ndarray:
    p = loop.plant
    n = p.e.shape[0]
    z = np.exp(1j * theta)
    zm1 = -2.0 * np.sin(theta / 2) ** 2 + 1j * np.sin(theta)
    mats = zm1[:, None, None] * np.eye(n) - p.e[None, :, :]
    rhs = p.g0[None, :] + p.g1[None, :] / z[:, None]
    g = (np.linalg.solve(mats, rhs[:, :, None])[:, :, 0] @ p.c) * np.exp(-1j * p.d * theta)
    g = g + loop.direct * np.exp(-1j * (p.d + 1) * theta)
    zz, pp, k = loop.zpk
    filt = k * np.prod(z[:, None] - zz[None, :], axis=1) / np.prod(z[:, None] - pp[None, :], axis=1)
    return 1.0 + force_gain * filt * g


def precise_return_difference(loop: FeedforwardLoop, force_gain: float, digits: int = PRECISE_DIGITS):
    """θ ↦ 1 + K_f·D(z)·G_1(z) in mpmath (θ an mpf): G_1 from :meth:`FeedforwardLoop.precise_plant`, D(z) from the
    same zeros, poles and gain as the double loop (the doubles taken as exact); None without the continuous plant."""
    plant = loop.precise_plant(digits)
    if plant is None:
        return None
    with mp.workdps(digits + 10):
        zeros = [mp.mpc(complex(x)) for x in loop.zpk[0]]
        poles = [mp.mpc(complex(x)) for x in loop.zpk[1]]
        gain, kf = mp.mpf(loop.zpk[2]), mp.mpf(force_gain)

    def f(theta):
        with mp.workdps(digits + 10):
            z = mp.expj(theta)
            filt = gain
            for q in zeros:
                filt *= z - q
            for q in poles:
                filt /= z - q
            return 1 + kf * filt * mp_sampled_response(plant, theta)
    return f


def feedforward_unstable_count(loop: FeedforwardLoop, force_gain: float, digits: int | None = PRECISE_DIGITS
                               ) -> UnstableCount:
    """Poles of the feedforward loop outside the unit circle, by the argument principle.

    Open-loop poles exactly at z = 1 (a grasp without stiffness on an undamped device) are indented; other
    poles on the circle (an undamped mode) make the count not checkable.  A closed-loop pole that double precision
    places within its own reach of the circle is decided in ``digits``-digit mpmath (optim.stability.circle_reach,
    as verify's stiffness count does); ``digits=None``: double precision alone."""
    q = 1.0 + np.linalg.eigvals(loop.plant.e)
    m1 = int(np.sum(q == 1.0))
    rest = q[q != 1.0]
    if np.any(np.abs(np.abs(rest) - 1.0) < 1e-14):
        return UnstableCount(None, 0, "an open-loop pole lies on the unit circle away from z = 1")
    poles = np.concatenate([q, loop.zpk[1].astype(complex)])
    precise = None if digits is None else precise_return_difference(loop, force_gain, digits)
    return count_outside(lambda th: _return_difference(loop, force_gain, th), poles, loop.plant.d, m1,
                         precise=precise, digits=digits or PRECISE_DIGITS)
