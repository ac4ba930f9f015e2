"""Random releases near K_cr and their independent verdict (issue 17: "diverging simulations called stable").

A case is a device (rigid or cable, T, fractional delay), a wall damping B below B_max, a stiffness
K = factor · K_cr(B) with factor in [0.8, 1.25], and a release from 1 mm lasting 0.3-20 s.  The
reference verdict comes from two methods that share no code with the simulator's poles:

  * tests/optim/independent.py: the closed-loop state matrix assembled in its own coordinates
    (dimensionless, physical states, its own delay register), its spectral radius;
  * optim.stability.margins.critical_stiffness: stable iff K < K_cr(B) (the crossover scan).

The two must agree with each other (else the case is reported, never silently skipped); a verdict
of the simulator contradicts them when it says stable (unstable) where they say unstable (stable).
``undetermined`` never contradicts.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.simulate import simulate
from optim.scene_verdict import with_margin_verdict
from optim.stability.margins import critical_stiffness, max_stable_damping
from tests.optim.independent import spectral_radius

__all__ = ["VerdictCase", "Outcome", "random_case", "run_case", "FACTORS", "DURATIONS"]

FACTORS = (0.8, 1.25)
DURATIONS = (0.3, 20.0)
#: Factors this close to 1 put a pole within the reference's own rounding of the circle: skipped as
#: ambiguous (the simulator may still answer; only a contradiction would count).
AMBIGUOUS = 1e-6


@dataclass(frozen=True)
class VerdictCase:
    device: Device
    damping: float
    stiffness: float
    factor: float
    duration: float

    def scene(self) -> Scene:
        eff = {"delay": {}} | ({"cable_mode": {}} if self.device.cable is not None else {})
        return Scene(experiment="release", duration=self.duration, initial={"position": 1e-3},
                     controller={"stiffness": self.stiffness, "damping": self.damping}, effects=eff)


@dataclass(frozen=True)
class Outcome:
    case: VerdictCase
    reference: str
    """stable / unstable from the independent spectral radius (checked against K_cr)."""
    radius: float
    verdict: str
    measured: str
    decided_by: str
    disagreement: str | None
    seconds: float

    @property
    def contradiction(self) -> bool:
        return self.verdict in ("stable", "unstable") and self.verdict != self.reference

    @property
    def measured_contradiction(self) -> bool:
        return self.measured in ("stable", "unstable") and self.measured != self.reference


def random_case(rng: np.random.Generator, cable: bool, long_delay: bool = False) -> VerdictCase:
    """``long_delay``: 600–1200 samples, beyond the poles' limit (decided by K_cr(B), optim/scene_verdict.py)."""
    t = float(10 ** rng.uniform(-4, math.log10(2e-3)))
    delay = float(rng.uniform(0.0, 6.0) * t) if rng.random() < 0.8 else float(rng.integers(0, 40) * t)
    if long_delay:
        delay = float(rng.uniform(600.0, 1200.0) * t)
    if cable:
        m_r, m_d = float(10 ** rng.uniform(-1.3, 0.5)), float(10 ** rng.uniform(-0.5, 1.2))
        c = {"motor_mass": m_r, "body_mass": m_d, "motor_damping": float(10 ** rng.uniform(-2, 1)),
             "body_damping": float(10 ** rng.uniform(-2, 1.3)), "stiffness": float(10 ** rng.uniform(3.5, 5.5)),
             "damping": float(10 ** rng.uniform(-2, 1.3))}
        dev = Device(cable=c, sample_time=t, delay=delay)
    else:
        dev = Device(mass=float(10 ** rng.uniform(-0.7, 1.3)), damping=float(10 ** rng.uniform(-1.5, 1.3)),
                     sample_time=t, delay=delay)
    b_max = max_stable_damping(dev)
    b = float(rng.choice([0.0, rng.uniform(0.0, 0.8)])) * (b_max if math.isfinite(b_max) else 0.0)
    k_cr = critical_stiffness(dev, b).critical_stiffness
    factor = float(rng.uniform(*FACTORS))
    duration = float(10 ** rng.uniform(math.log10(DURATIONS[0]), math.log10(DURATIONS[1])))
    duration = max(duration, 2 * delay)               # a release must outlast its delay to say anything
    return VerdictCase(dev, b, factor * k_cr, factor, duration)


def run_case(case: VerdictCase) -> Outcome | None:
    """The simulator's verdicts and the independent reference; None when the case is ambiguous."""
    dev = case.device
    if abs(case.factor - 1.0) < AMBIGUOUS:
        return None
    alpha = case.stiffness * dev.sample_time ** 2 / dev.mass
    beta = case.damping * dev.sample_time / dev.mass
    radius = spectral_radius(dev, alpha, beta)
    reference = "stable" if radius < 1.0 else "unstable"
    by_kcr = "stable" if case.factor < 1.0 else "unstable"
    if reference != by_kcr:
        raise AssertionError(f"the two references disagree on {case}: radius {radius!r}, factor {case.factor}")
    start = time.perf_counter()
    scene = case.scene()
    res = with_margin_verdict(dev, scene, simulate(dev, scene))      # what the route answers (service/jobs.py)
    j = res.judgement
    return Outcome(case, reference, radius, res.verdict.state, j.measured.state, j.decided_by, j.disagreement,
                   time.perf_counter() - start)
