"""Random cable devices for the cable tests (test_cable_brackets, test_fast_cable): one generator, each test's
distribution given as parameters (the draws, and so each seed's devices, as each test drew them before)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from models.device import Device


def random_cable(rng: np.random.Generator, i: int, *, low: int = 0, top: int = 200, short_top: int | None = None,
                 cable_damping: str = "critical", undamped: Callable[[int], bool] | None = None) -> Device:
    """The i-th random cable: T ∈ {0.5, 1, 2} ms, m 1e-3–10 kg, δ 1e-10–1, motor mass 5–90 % of m, cable mode
    10 rad/s–0.9·Nyquist, delay [low, top] samples (whole for odd i, fractional for even), or [0, short_top) for
    every fifth i when ``short_top`` is given.  ``cable_damping``: "critical" draws it 1e-9–10× critical (a
    resonance down to 1e-9 from the unit circle), "absolute" 0–10 N·s/m spread over five decades; ``undamped(i)``:
    every damping 0 (the lossless cable)."""
    t = float(rng.choice([5e-4, 1e-3, 2e-3]))
    m = 10 ** rng.uniform(-3, 1)
    delta = 10 ** rng.uniform(-10, 0)
    ds = float(rng.integers(low, top + 1)) if i % 2 else float(rng.uniform(low, top))
    if short_top is not None and i % 5 == 0:
        ds = float(rng.integers(0, short_top)) if i % 2 else float(rng.uniform(0, short_top))
    mr = m * rng.uniform(0.05, 0.9)
    md = m - mr
    wn = min(10 ** rng.uniform(1, 4), 0.9 * math.pi / t)
    kc = wn ** 2 * mr * md / m
    b = delta * m / t
    br = b * rng.uniform(0, 1)
    if cable_damping == "critical":
        bc = 2.0 * math.sqrt(kc * mr * md / m) * 10 ** rng.uniform(-9, 1)
    else:
        bc = rng.uniform(0, 1) * 10 ** rng.uniform(-4, 1)
    if undamped is not None and undamped(i):
        br, b, bc = 0.0, 0.0, 0.0
    return Device(cable=dict(motor_mass=mr, body_mass=md, motor_damping=br, body_damping=b - br,
                             stiffness=kc, damping=bc), sample_time=t, delay=ds * t)
