"""Misspecified records (issue 34): data that the asked model cannot explain, each from the scene simulator.

* a cable device fitted as rigid (the LHifAM's 84 Hz mode excited, model "rigid");
* a missing delay: the record has 3.3 ms of delay but the fit is told ``known.delay = 0``;
* an unlogged force saturation: the motor clipped the command at 1.2 N, the log holds the command (±3 N);
* drifting noise: a slow random walk (σ 20 µm per √s) on the encoder besides its white noise.
"""

from __future__ import annotations

import numpy as np

from models.device import Device
from optim.identification import TimeSeriesData
from tests.optim.identification.cases import AMPLITUDE, NOISE, QUANTIZATION, T, device
from tests.optim.identification.synthetic import RIGID, excitation, simulate_experiment

__all__ = ["MISSPECIFIED", "misspecified", "TRUE_MASS"]

N = 4000
#: the true total mass of both devices (rigid 5.4; cable 0.3 + 5.1)
TRUE_MASS = 5.4
SATURATION = 1.2


def misspecified(case: str, seed: int = 0) -> tuple[TimeSeriesData, dict]:
    """(record, identify's keyword arguments) of one misspecified case."""
    u = excitation(N, T, amplitude=AMPLITUDE, seed=seed)
    rng = np.random.default_rng(seed + 17)
    if case == "cable_as_rigid":
        y = simulate_experiment(device("cable", 0.0), u, quantization=QUANTIZATION, noise=NOISE, seed=seed)
        return TimeSeriesData(T, u, y), {"model": "rigid"}
    if case == "missing_delay":
        y = simulate_experiment(device("rigid", 0.0033), u, quantization=QUANTIZATION, noise=NOISE, seed=seed)
        return TimeSeriesData(T, u, y), {"model": "rigid", "known": {"delay": 0.0}}
    if case == "saturation":
        y = simulate_experiment(Device(**RIGID), np.clip(u, -SATURATION, SATURATION), quantization=QUANTIZATION,
                                noise=NOISE, seed=seed)
        return TimeSeriesData(T, u, y), {"model": "rigid"}
    if case == "drifting_noise":
        y = simulate_experiment(Device(**RIGID), u, quantization=0.0, noise=NOISE, seed=seed)
        y = y + np.cumsum(rng.normal(0.0, 20e-6 * np.sqrt(T), N))
        return TimeSeriesData(T, u, QUANTIZATION * np.round(y / QUANTIZATION)), {"model": "rigid"}
    raise ValueError(case)


MISSPECIFIED = ("cable_as_rigid", "missing_delay", "saturation", "drifting_noise")
