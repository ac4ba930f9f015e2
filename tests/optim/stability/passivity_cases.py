"""Random and aimed walls for the passivity property run (bench/bench_passivity.py, test_passivity_bound.py).

Random: T 10 µs–10 ms, delays 0–5,000 samples (whole or fractional), K up to 10× the no-delay passive bound,
B = 0 or up to 100× b.  Aimed: the physical damping b put within 1e-13–1e-5 (relative, either side) of the mpmath
sup of P, so that the label turns on the last digits; a third with K·T/2·(2d + 1) ≪ B (nearly equal lobes: B close
to the required damping), delays up to 5,000 samples, half of them fractional (the test rounds up)."""

from __future__ import annotations

import math

import numpy as np

from models.device import Device

from .passivity_mp import mp_sup


def _delay_samples(rng: np.random.Generator) -> float:
    u = rng.random()
    d = rng.uniform(0, 40) if u < 0.55 else rng.uniform(40, 400) if u < 0.85 else rng.uniform(400, 5000)
    return float(math.floor(d)) if rng.random() < 0.45 else float(d)


def whole_samples(delay_samples: float) -> int:
    """⌈t_d/T⌉ (the contract), with the 64-ulp snap of a quotient meant as a whole number."""
    n = round(delay_samples)
    if abs(delay_samples - n) <= 64 * 2.220446049250313e-16 * max(1.0, delay_samples):
        return int(n)
    return int(math.ceil(delay_samples))


def random_wall(rng: np.random.Generator) -> tuple[Device, float, float]:
    t = float(10 ** rng.uniform(-5, -2))
    ds = _delay_samples(rng)
    b = float(10 ** rng.uniform(-3, 2))
    dev = Device(mass=float(10 ** rng.uniform(-3, 1.5)), damping=b, sample_time=t, delay=ds * t)
    k = float(b / (t / 2 + ds * t) * 10 ** rng.uniform(-2, 1))
    big_b = 0.0 if rng.random() < 0.1 else float(b * 10 ** rng.uniform(-3, 2))
    return dev, k, big_b


def aimed_wall(rng: np.random.Generator) -> tuple[Device, float, float, float]:
    """(device, K, B, mp sup of P): b within 1e-13–1e-5 of the sup, on either side."""
    t = float(10 ** rng.uniform(-5, -2))
    ds = _delay_samples(rng)
    d = whole_samples(ds)
    big_b = float(10 ** rng.uniform(-2, 4))
    hk_max = big_b / (2 * d + 1)
    if rng.random() < 0.35:     # nearly equal lobes: K·T/2·(2d + 1) far below B
        hk = hk_max * 10 ** rng.uniform(-5, -1)
    else:
        hk = hk_max * 10 ** rng.uniform(-1, 2)
    k = float(2 * hk / t)
    sup, _, _ = mp_sup(k * t / 2, big_b, d)
    rel = 10 ** rng.uniform(-13, -5) * (1 if rng.random() < 0.5 else -1)
    b = sup * (1 + rel)
    dev = Device(mass=float(10 ** rng.uniform(-3, 1.5)), damping=b, sample_time=t, delay=ds * t)
    return dev, k, big_b, sup
