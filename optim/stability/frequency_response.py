"""Frequency response of the sampled stiffness loop's plant, for Bode diagrams.

G(e^{jωT}) = Z[H(s)·G_r(s)·e^{−t_d s}] evaluated on the unit circle (chapter
eq. 20-21; the rigid model's G when the device has no cable), in physical units
[m/N or rad/(N·m)]: the dimensionless plant of models.plants is G·m/T², so it is
divided by device.stiffness_scale.  The phase crossovers marked on the diagram
are those of optim.stability.margins.critical_stiffness for the same virtual damping: with
B = 0 they are exactly where the phase is −180° (mod 360°) and |G| = 1/K_i.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.plants import stiffness_loop_plant
from optim.errors import InputError
from optim.stability.margins import critical_stiffness

__all__ = ["CrossoverPoint", "FrequencyResponse", "plant_response", "loop_frequency_response",
           "MAX_RESPONSE_POINTS"]

#: Cost limit: frequencies in one response.
MAX_RESPONSE_POINTS = 5000
#: Lowest frequency of the default grid, as an angle per sample (ωT).
_THETA_LOW = 1e-3


@dataclass(frozen=True)
class CrossoverPoint:
    """A phase crossover of K_cr(B) as it sits on the Bode diagram of G."""

    frequency: float
    """ω [rad/s]."""
    stiffness: float
    """K [N/m] that puts a closed-loop pole at e^{jωT} (with the analysed B)."""
    magnitude: float
    """|G(e^{jωT})| [m/N]."""
    phase_deg: float
    """arg G(e^{jωT}) [deg], on the same branch as the diagram's phase."""


@dataclass(frozen=True)
class FrequencyResponse:
    frequency: np.ndarray
    """ω [rad/s], log-spaced from 1e-3/T to the Nyquist frequency π/T."""
    magnitude: np.ndarray
    """|G(e^{jωT})| [m/N]."""
    phase_deg: np.ndarray
    """arg G(e^{jωT}) [deg], continuous (the whole-sample delay's −d·ωT added analytically)."""
    crossovers: tuple[CrossoverPoint, ...]
    critical_stiffness: float
    """K_cr(B) [N/m] (inf when every K > 0 is stable, 0 when none is)."""
    damping: float
    """B [N·s/m] the crossovers are for."""
    nyquist_frequency: float
    """π/T [rad/s]."""


def plant_response(device: Device, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(|G(e^{jωT})| [m/N], continuous phase [deg]) at the frequencies ω [rad/s] (ascending, ≤ π/T).

    The phase of the whole-sample delay z^{−d} is added as −d·ωT rather than
    unwrapped from samples: with hundreds of samples of delay the phase turns
    faster than any plotting grid resolves, and np.unwrap would guess.
    """
    plant = stiffness_loop_plant(device)
    theta = np.asarray(omega, dtype=float) * device.sample_time
    g = plant.response(theta) / device.stiffness_scale
    without_delay = g * np.exp(1j * plant.d * theta)  # smooth: only the fractional delay and the dynamics remain
    phase = np.unwrap(np.angle(without_delay)) - plant.d * theta
    return np.abs(g), np.degrees(phase)


def loop_frequency_response(device: Device, damping: float = 0.0, points: int = 400) -> FrequencyResponse:
    """Bode data of G on ``points`` log-spaced frequencies, with the crossovers of K_cr(B) marked."""
    if not (10 <= points <= MAX_RESPONSE_POINTS):
        raise InputError("points", f"must be between 10 and {MAX_RESPONSE_POINTS}")
    t = device.sample_time
    omega = np.geomspace(_THETA_LOW, math.pi, points) / t
    omega[-1] = math.pi / t  # geomspace's last point may differ from π/T by an ulp
    crit = critical_stiffness(device, damping)
    cross = np.array([c.frequency for c in crit.crossovers], dtype=float)
    # One call on the merged grid so that the crossovers' phases sit on the plotted branch.
    merged = np.union1d(omega, cross)
    mag, phase = plant_response(device, merged)
    where = np.searchsorted(merged, cross)
    marks = tuple(CrossoverPoint(frequency=c.frequency, stiffness=c.stiffness, magnitude=float(mag[i]),
                                 phase_deg=float(phase[i])) for c, i in zip(crit.crossovers, where))
    keep = np.searchsorted(merged, omega)
    return FrequencyResponse(frequency=omega, magnitude=mag[keep], phase_deg=phase[keep], crossovers=marks,
                             critical_stiffness=crit.critical_stiffness, damping=damping,
                             nyquist_frequency=math.pi / t)
