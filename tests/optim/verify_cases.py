"""Random devices for the verify property test and bench/bench_verify.py (one generator, two sizes)."""

from __future__ import annotations

import math

import numpy as np

from models.device import Device


def random_device(rng: np.random.Generator) -> Device:
    """Rigid or cable, δ = bT/m log-uniform down to 10^-9.5 and 0 (one in twenty), delays 0–10,000
    samples (whole, fractional, short and long), sample times 30 µs–10 ms."""
    t = 10 ** rng.uniform(-4.5, -2)
    m = 10 ** rng.uniform(-1, 1.5)
    delta = 10 ** rng.uniform(-10, 0)
    kind = rng.integers(0, 5)
    d = [0.0, float(rng.integers(1, 6)), rng.uniform(0, 40), rng.uniform(0, 1000), rng.uniform(0, 10_000)][kind]
    if rng.random() < 0.3:
        d = float(round(d))
    kw = dict(sample_time=t, delay=d * t)
    # δ's lowest twentieth (1e-10 … 10^-9.5) becomes δ = 0: frictionless devices (rigid b = 0; a cable with
    # b_r = b_d = 0), with no extra draw, so that every other device of a seed stays what it was
    b = delta * m / t if delta >= 10 ** -9.5 else 0.0
    if rng.random() < 0.5:
        return Device(mass=m, damping=b, **kw)
    mr = m * rng.uniform(0.05, 0.5)
    md = m - mr
    wn = min(10 ** rng.uniform(1, 4), 0.9 * math.pi / t)   # the cable mode below Nyquist
    kc = wn ** 2 * mr * md / m
    br = b * rng.uniform(0, 1)
    bc = rng.uniform(0, 1) * 10 ** rng.uniform(-3, 1)
    if rng.random() < 0.05:   # the undamped cable: every damping zero
        br, b, bc = 0.0, 0.0, 0.0
    return Device(cable=dict(motor_mass=mr, body_mass=md, motor_damping=br, body_damping=b - br,
                             stiffness=kc, damping=bc), **kw)


def undamped_cable(device: Device) -> bool:
    c = device.cable
    return c is not None and c.motor_damping == c.body_damping == c.damping == 0.0
