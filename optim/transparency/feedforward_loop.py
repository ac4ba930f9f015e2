"""The exact force-feedforward loop over a set of grasps, and the band and grasps an inertia design searches.

Shared by the inertia design (optim.transparency.inertia), its robust form (optim.robust.inertia), the design
ladder (optim.design_ladder) and the band search (optim.transparency.inertia_band): one public home for what
they all evaluate, so none of them imports another module's private names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.device import Device, Human
from models.feedforward import feedforward_plant
from optim.errors import InputError
from optim.transparency.feedforward import critical_force_gain_of_plant, resolve_human
from optim.transparency.inertia_requirements import InertiaRequirements

__all__ = ["FeedforwardLoop", "RigidComparison", "RIGID_OPTIMISM_FLAG", "RANGE_START_MASSES", "cutoff_band",
           "design_humans", "rigid_comparison", "upper_cutoff_hz"]

#: Flag the rigid model when its critical K_f exceeds the cable model's by more than this.
RIGID_OPTIMISM_FLAG = 0.20
#: Grasp masses a range starts with (geometric, ends included).
RANGE_START_MASSES = 5


@dataclass(frozen=True)
class RigidComparison:
    critical_force_gain: float
    """What the rigid model (m = m_r + m_d) claims K_f,cr is at the design's cutoff."""
    force_gain: float
    """The K_f it would have allowed with the required margin."""
    optimism: float
    """K_f,cr(rigid)/K_f,cr(cable) - 1."""
    optimistic: bool
    """optimism > 20 %: the rigid model would have over-promised."""


def upper_cutoff_hz(device: Device, cutoff_max_hz: float | None = None) -> tuple[float, str]:
    """The top of the cutoff band [Hz] and where it comes from: ``cutoff_max_hz`` when given, else the
    first cable mode ω_n/2π (eq. 24) when it lies below Nyquist, else 0.4 × Nyquist."""
    nyq = 0.5 / device.sample_time
    if cutoff_max_hz is not None:
        return cutoff_max_hz, "requirements"
    if device.cable is not None and device.cable.natural_frequency / (2 * math.pi) < nyq:
        return device.cable.natural_frequency / (2 * math.pi), "first cable mode ω_n/2π (eq. 24)"
    return 0.4 * nyq, "0.4 × Nyquist (no cable mode below Nyquist)"


def cutoff_band(device: Device, req: InertiaRequirements) -> tuple[float, float, str]:
    """The cutoff band [Hz] (low, high) of a design and where its top comes from; InputError names a bad end."""
    nyq = 0.5 / device.sample_time
    hi, src = upper_cutoff_hz(device, req.cutoff_max_hz)
    if not hi < nyq:
        raise InputError("requirements.cutoff_max_hz", f"must be below the Nyquist frequency {nyq:g} Hz, got {hi:g}")
    if not req.cutoff_min_hz < hi:
        raise InputError("requirements.cutoff_min_hz", f"must be below the upper cutoff {hi:g} Hz ({src}), "
                         f"got {req.cutoff_min_hz:g}")
    return req.cutoff_min_hz, hi, src


def design_humans(device: Device, req: InertiaRequirements) -> tuple[list[Human], str]:
    """The grasps a design starts with and where they come from (explicit list, mass range or the device's)."""
    if req.humans:
        return list(req.humans), "requirements.humans"
    base, src = resolve_human(device)
    if req.human_mass_range is None:
        return [base], src
    lo, hi = req.human_mass_range.min, req.human_mass_range.max
    masses = np.geomspace(lo, hi, RANGE_START_MASSES) if hi > lo else [lo]
    return [base.model_copy(update={"mass": float(m)}) for m in masses], \
        f"requirements.human_mass_range with damping/stiffness of {src}"


class FeedforwardLoop:
    """The exact K_f,cr(θ_c) of one device over a set of grasps (worst grasp).

    ``cutoff_scales[j]`` maps θ_c to plant j's own cutoff angle (1 here: one device, one sample time;
    optim.robust.inertia's devices of other sample times see the same cutoff in Hz at θ_c·T_j/T_ref).
    """

    def __init__(self, device: Device, humans: list[Human], order: int):
        self.device, self.humans, self.order = device, humans, order
        self.plants = [feedforward_plant(device, h) for h in humans]
        self.cutoff_scales = [1.0] * len(self.plants)
        self._memo: dict[float, tuple] = {}

    def exact(self, theta_c: float) -> tuple[float, float | None, int, list[tuple[int, float]]]:
        """(K_f,cr, θ of its crossover, index of the worst grasp, every (grasp, θ) crossover)."""
        theta_c = float(theta_c)
        if theta_c not in self._memo:
            self._memo[theta_c] = self._exact(theta_c)
        return self._memo[theta_c]

    def structure(self, theta_c: float) -> tuple[int, ...]:
        """How many crossovers each grasp's loop has at this cutoff."""
        found = self.exact(theta_c)[3]
        return tuple(sum(1 for j, _ in found if j == i) for i in range(len(self.plants)))

    def _exact(self, theta_c: float) -> tuple[float, float | None, int, list[tuple[int, float]]]:
        best, where, who, found = math.inf, None, 0, []
        for j, plant in enumerate(self.plants):
            k, th, pairs = critical_force_gain_of_plant(plant, theta_c * self.cutoff_scales[j], self.order)
            found += [(j, a) for a, _ in pairs]
            if k < best:
                best, where, who = k, th, j
        return best, where, who, found


def rigid_comparison(device: Device, humans: list[Human], order: int, cutoff_hz: float,
                     kcr: float, rho: float) -> RigidComparison | None:
    """What the rigid model of a cable device claims at ``cutoff_hz`` against the cable model's K_f,cr ``kcr``,
    with the margin ratio ρ = 10^{GM/20}; None for a rigid device."""
    if device.cable is None:
        return None
    rigid = FeedforwardLoop(device.rigid(), humans, order)
    k_r = rigid.exact(2 * math.pi * cutoff_hz * device.sample_time)[0]
    optimism = k_r / kcr - 1.0
    return RigidComparison(critical_force_gain=k_r, force_gain=k_r / rho, optimism=optimism,
                           optimistic=optimism > RIGID_OPTIMISM_FLAG)
