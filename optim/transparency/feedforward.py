"""Critical force-feedforward gain K_f,cr of the sampled loop (chapter §5, eq. 29-34).

The loop 1 + K_f·D(z)·G_1(z) = 0 has a pole at z = e^{jθ} exactly when
K_f = h(θ) = -1/(D(e^{jθ})·G_1(e^{jθ})).  G_1 and D are stable, so at K_f = 0⁺
every pole is inside the unit circle and K_f,cr is the minimum of h over every
θ in (0, π] where h is real and positive (the Nyquist point included: without a
filter the LHifAM's crossover is there, eq. 32).

The crossings are searched on h̃ = -conj(G_1)·Q (no filter: -conj(G_1)), with
D = cosⁿφ/Q (models/filters.py): h̃ = h·cosⁿφ·|G_1|² has the phase of h (so the
same crossings and the same sign of its real part) but stays finite and nonzero
where D vanishes (D(-1) = 0 for the bilinear Butterworth).  Evaluating h itself
would divide by zero at π, and a zero of h̃ has no phase, which would make the
adaptive scan bisect towards π forever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.device import Device, Human
from models.feedforward import CHAPTER_HUMAN, FeedforwardPlant, feedforward_plant
from models.filters import ButterworthLowPass, butterworth_denominator
from optim.errors import InputError
from optim.stability.crossovers import positive_real_crossings, scan_grid

__all__ = ["ForceCrossover", "CriticalForceGain", "critical_force_gain", "critical_force_gain_of_plant",
           "worst_case_force_gain", "apparent_mass", "force_gain_margin_db", "resolve_human"]


@dataclass(frozen=True)
class ForceCrossover:
    """A phase crossover of K_f·D·G_1 with the gain that puts a closed-loop pole there."""

    frequency: float
    """ω [rad/s]; π/T is the Nyquist frequency."""
    force_gain: float
    """K_f [dimensionless] giving a closed-loop pole at e^{jωT}."""


@dataclass(frozen=True)
class CriticalForceGain:
    """K_f,cr of one device, human and filter, with every crossover."""

    critical_force_gain: float
    """K_f,cr [dimensionless]; inf when no K_f > 0 destabilises the loop."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets K_f,cr (None when there is none)."""
    crossovers: tuple[ForceCrossover, ...]
    """All phase crossovers with K_f > 0, by frequency."""
    worst_case_force_gain: float
    """1 + m/m_h, eq. 33: the flat inertial part of G_1 [dimensionless]."""
    human: Human
    human_source: str
    """Where the human model came from: "request", "device" or "chapter eq. 30 (default)"."""
    reason: str | None = None


def resolve_human(device: Device, human: Human | None = None) -> tuple[Human, str]:
    """The grasp to analyse with and where it came from (explicit > device > eq. 30)."""
    if human is not None:
        return human, "request"
    if device.human is not None:
        return device.human, "device"
    return CHAPTER_HUMAN, "chapter eq. 30 (default: the device has no human block)"


def worst_case_force_gain(device: Device, human: Human) -> float:
    """K_f,cr^W = 1 + m/m_h, eq. 33 [dimensionless]."""
    return 1.0 + device.mass / human.mass


def apparent_mass(device: Device, force_gain: float) -> float:
    """m/(1 + K_f), eq. 28 [kg or kg·m²]."""
    return device.mass / (1.0 + force_gain)


def force_gain_margin_db(critical: float, force_gain: float) -> float:
    """20·log10(K_f,cr/K_f) [dB] (eq. 13's definition applied to eq. 34)."""
    return 20.0 * math.log10(critical / force_gain)


_PER_DECADE = 12   # log samples per decade: < 2π of phase per step even for a 4th-order cutoff;
                  # the arg-turn refinement of optim/stability/crossovers.py bisects the rest


def _grid(plant: FeedforwardPlant, cutoff_angle: float | None) -> np.ndarray:
    """scan_grid plus log samples where G_1 and D have structure far below its linear part.

    scan_grid's log part spans only one decade above θ_min and its linear step is 0.02 rad:
    the grasp's poles and zeros (~1e-3 rad/sample at 1 kHz) and a low filter cutoff (whose
    phase turns by n·90° over about a decade) would sit inside one linear interval, where a
    full phase turn can hide a crossover.  The Butterworth is not resonant, so its cutoff
    gets a log band, not a dense cluster.
    """
    theta_min = plant.theta_min if cutoff_angle is None else min(plant.theta_min, 1e-2 * cutoff_angle)
    parts = [scan_grid(theta_min, plant.d + plant.f, plant.hints, width_hint=plant.width_hint)]
    top = 0.05
    if theta_min < top:
        parts.append(np.geomspace(theta_min, top, int(_PER_DECADE * math.log10(top / theta_min)) + 2))
    if cutoff_angle is not None:
        lo, hi = 1e-2 * cutoff_angle, min(math.pi, 1e2 * cutoff_angle)
        parts.append(np.geomspace(lo, hi, int(_PER_DECADE * math.log10(hi / lo)) + 2))
    return np.unique(np.concatenate(parts))


def critical_force_gain_of_plant(plant: FeedforwardPlant, cutoff_angle: float | None,
                                 order: int = 2) -> tuple[float, float | None, tuple[tuple[float, float], ...]]:
    """(K_f,cr, θ of the crossover that sets it, all (θ, K_f) crossings) for a built plant.

    ``cutoff_angle`` θ_c [rad/sample] of the Butterworth D, or None for no filter.
    """
    if cutoff_angle is None:
        def h_tilde(theta: np.ndarray) -> np.ndarray:
            return -np.conj(plant.response(theta))

        def gain(theta: np.ndarray, value: np.ndarray) -> np.ndarray:
            return 1.0 / value
    else:
        def h_tilde(theta: np.ndarray) -> np.ndarray:
            return -np.conj(plant.response(theta)) * butterworth_denominator(theta, cutoff_angle, order)[1]

        def gain(theta: np.ndarray, value: np.ndarray) -> np.ndarray:
            # h = h̃ / (cosⁿφ·|G_1|²): the positive factor h̃ carries (models/filters.py)
            cn = butterworth_denominator(theta, cutoff_angle, order)[0]
            return value / (cn * np.abs(plant.response(theta)) ** 2)
    found = positive_real_crossings(h_tilde, _grid(plant, cutoff_angle))
    if cutoff_angle is not None:
        # D(-1) = 0: no finite gain puts a pole at z = -1 through a bilinear filter.
        found = [c for c in found if c.angle < math.pi]
    if not found:
        return math.inf, None, ()
    angles = np.array([c.angle for c in found])
    gains = gain(angles, np.array([c.value for c in found]))
    pairs = tuple((float(a), float(k)) for a, k in zip(angles, gains))
    best = min(pairs, key=lambda c: c[1])
    return best[1], best[0], pairs


def critical_force_gain(device: Device, filter: ButterworthLowPass | None = None,
                        human: Human | None = None) -> CriticalForceGain:
    """Exact K_f,cr = Gm{D(z)·G_1(z)} (eq. 32/34) for the device's own model (cable if present)."""
    if filter is not None and not math.isclose(filter.sample_time, device.sample_time, rel_tol=1e-12):
        raise InputError("filter", "its sample_time must be the device's sample_time")
    hm, source = resolve_human(device, human)
    plant = feedforward_plant(device, hm)
    kcr, theta, found = critical_force_gain_of_plant(
        plant, filter.cutoff_angle if filter is not None else None, filter.order if filter is not None else 2)
    t = device.sample_time
    crossovers = tuple(ForceCrossover(frequency=a / t, force_gain=k) for a, k in found)
    reason = None if found else "no phase crossover: every positive force gain is stable"
    return CriticalForceGain(critical_force_gain=kcr, crossover_frequency=None if theta is None else theta / t,
                             crossovers=crossovers, worst_case_force_gain=worst_case_force_gain(device, hm),
                             human=hm, human_source=source, reason=reason)
