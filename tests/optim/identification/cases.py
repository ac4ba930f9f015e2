"""The identification tests' reference cases in one place: devices, noise levels and tolerances.

Noise levels ("realistic"): encoder quantisation q = 5 µm and Gaussian measurement noise σ = 5 µm on
the position (a 1 µm optical encoder is finer; a noisy analog read-out is comparable); excitation
±3 N (a chirp 0.5-200 Hz plus a PRBS), 4,000 samples at T = 1 ms; Coulomb friction 0.03 N, 1 % of the
excitation (at 5 % the delay error reaches 0.6 ms: the friction term is an approximation,
docs/identification.md).
Tolerances are those of issue 21: 1 % on masses (and the cable stiffness), 10 % on dampings, T/20 on
the delay.  For the cable device the motor and body dampings are not separately determined by a
motor-side encoder at this noise (their sum is, see test_cable_recovery_and_auto), so the 10 % applies
to their sum b_r + b_d and to the cable damping b_c (15 % with friction, test_cable_with_friction).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from models.device import Device
from optim.identification import TimeSeriesData
from tests.optim.identification.synthetic import CABLE, RIGID, excitation, simulate_experiment

T = 0.001
N = 4000
AMPLITUDE = 3.0
QUANTIZATION = 5e-6
NOISE = 5e-6
FRICTION = 0.03
MASS_RTOL = 0.01
DAMPING_RTOL = 0.10
DELAY_ATOL = T / 20
#: delays of the recovery tests [s]: none, fractional, whole, fractional beyond a few samples
DELAYS = (0.0, 0.0007, 0.002, 0.0033)


def device(kind: str, delay: float) -> Device:
    return Device(**(RIGID if kind == "rigid" else CABLE), delay=delay)


@cache
def record(kind: str, delay: float, friction: float = 0.0, seed: int = 0, n: int = N,
           noise: float = NOISE, quantization: float = QUANTIZATION) -> TimeSeriesData:
    u = excitation(n, T, amplitude=AMPLITUDE, seed=seed)
    y = simulate_experiment(device(kind, delay), u, friction=friction, quantization=quantization, noise=noise,
                            seed=seed)
    return TimeSeriesData(sample_time=T, force=u, position=y)


def noisy_response(kind: str, delay: float, rel_noise: float = 0.01, points: int = 60, seed: int = 0,
                   kind_of_response: str = "continuous"):
    from optim.identification import FrequencyResponseData
    from optim.identification.models import response
    top = 2 * np.pi * (300 if kind_of_response == "continuous" else 450)
    w = np.geomspace(2 * np.pi * 1, top, points)
    h = response(device(kind, delay), w, kind_of_response)
    rng = np.random.default_rng(seed)
    h = h * (1 + rel_noise * (rng.normal(size=points) + 1j * rng.normal(size=points)) / np.sqrt(2))
    return FrequencyResponseData(frequency=w, response=h, sample_time=T, model_kind=kind_of_response)
