"""Random stiffness designs checked against the project's own analysis and a dense independent search (issue 17).

Shared by the CI property test (tests/optim/test_design_properties.py, reduced size) and the bench
(bench/bench_design_properties.py, full size, writing docs/properties_design.md).

A design's labels must agree with zwidth's own analysis of it:

* ``optimal`` ⇒ optim.stability.analysis (exact rung) at (K, B) says stable, its gain margin ≥ the requirement, passive
  when passivity is required, K and B within their caps, and the design's K_cr is the analysis' K_cr;
* ``infeasible`` ⇒ the dense B scan of tests/optim/stiffness_scan.py (exact K_cr at ~130 values of B, then
  bounded refinement; it shares no code with optim.stiffness) finds no (K > 0, B) meeting the requirements;
* ``failed`` is an honest "do not know" but counted: none is expected.

Optionally (``optimality=True``, for delays up to ``OPTIMALITY_MAX_DELAY`` samples where the scan is cheap),
an ``optimal`` K must not be below the scan's best by more than ``OPTIMALITY_RTOL``; the scan is skipped only
where it cannot find better: K equal to a cap on K (every wall the scan tries is capped there too).

Optionally (``verify=True``), an ``optimal`` design is verified independently (optim.verification
.verify_stiffness_design: the closed loop at the critical gain its margin implies, at K itself, and its
passivity recomputed): ``contradicted`` is a disagreement, ``not_checkable`` is counted with its reason.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from models.device import MAX_DELAY_SAMPLES, Device
from optim.errors import InputError
from optim.stability.analysis import analyse_stability
from optim.stiffness import StiffnessRequirements, design_stiffness
from optim.verification import verify_stiffness_design
from tests.optim.stiffness_scan import scan_best

OPTIMALITY_MAX_DELAY = 200
OPTIMALITY_RTOL = 1e-4


@dataclass
class Case:
    device: Device
    req: StiffnessRequirements
    label: str


@dataclass
class Outcome:
    case: Case
    status: str
    """optimal / infeasible / failed, or refused (the design raised InputError: a 422 over HTTP)."""
    problems: list[str] = field(default_factory=list)
    seconds: float = 0.0
    optimality_checked: bool = False
    verify: str | None = None
    """verify's verdict on an optimal design (confirmed / contradicted / not_checkable), None when not run."""
    verify_reason: str | None = None
    verify_seconds: float = 0.0


def _delay_samples(rng: np.random.Generator) -> float:
    u = rng.random()
    if u < 0.35:
        d = float(rng.integers(0, 21))
    elif u < 0.7:
        d = float(rng.uniform(0, 20))
    elif u < 0.85:
        d = float(10 ** rng.uniform(1.3, 3))
    else:
        d = float(10 ** rng.uniform(3, 4))
    if rng.random() < 0.5:
        d = float(round(d))
    if rng.random() < 0.03:
        d = float(MAX_DELAY_SAMPLES)
    return min(d, float(MAX_DELAY_SAMPLES))


def _delay(d: float, t: float) -> float:
    """d·T [s], rounded down to stay within the limit at d = MAX_DELAY_SAMPLES ((d·T)/T can exceed d by an ulp)."""
    delay = d * t
    while delay / t > MAX_DELAY_SAMPLES:
        delay = math.nextafter(delay, 0.0)
    return delay


def _damping(rng: np.random.Generator, scale: float, zero_p: float) -> float:
    """A physical damping b [N·s/m] with δ = bT/m from 1e-10 to ~1 (log-uniform), or 0 with probability zero_p."""
    if rng.random() < zero_p:
        return 0.0
    return float(10 ** rng.uniform(-10, 0)) * scale


def random_case(rng: np.random.Generator) -> Case:
    t = float(10 ** rng.uniform(-4.5, -2))
    if rng.random() < 0.02:
        t = 1.0                                  # the sample-time limit
    d = _delay_samples(rng)
    if rng.random() < 0.5:
        m = float(10 ** rng.uniform(-1.5, 1.5))
        dev = Device(mass=m, damping=_damping(rng, m / t, 0.05), sample_time=t, delay=_delay(d, t))
        kind = "rigid"
    else:
        m_r, m_d = float(10 ** rng.uniform(-1.5, 0.7)), float(10 ** rng.uniform(-0.5, 1.2))
        m = m_r + m_d
        zero_all = rng.random() < 0.08
        cable = dict(motor_mass=m_r, body_mass=m_d, stiffness=float(10 ** rng.uniform(2, 5.5)),
                     motor_damping=0.0 if zero_all else _damping(rng, m / t, 0.2),
                     body_damping=0.0 if zero_all else _damping(rng, m / t, 0.3),
                     damping=0.0 if zero_all else _damping(rng, m / t, 0.2))
        dev = Device(sample_time=t, delay=_delay(d, t), cable=cable)
        kind = "cable" + (" undamped" if zero_all else "")
    gm = float(rng.choice([0.0, 3.0, 6.0, 6.0, 12.0, float(rng.uniform(0, 20))]))
    kw: dict = {"min_gain_margin_db": gm, "passivity": bool(rng.random() < 0.3)}
    if rng.random() < 0.15:
        kw["max_damping"] = float(10 ** rng.uniform(-2, 1)) * dev.damping_scale * 0.1
    if rng.random() < 0.15:
        kw["max_stiffness"] = float(10 ** rng.uniform(-6, 0)) * dev.stiffness_scale
    label = (f"{kind}, T = {t:.3g} s, d = {d:.6g}, δ = {dev.delta:.2g}, GM {gm:.3g} dB"
             + (", passivity" if kw["passivity"] else "") + "".join(f", {k}" for k in kw if k.startswith("max")))
    return Case(dev, StiffnessRequirements(**kw), label)


def check(case: Case, optimality: bool = False, verify: bool = False) -> Outcome:
    dev, req = case.device, case.req
    t0 = time.perf_counter()
    try:
        d = design_stiffness(dev, req)
    except InputError as exc:
        # a 422 over HTTP (e.g. an undamped cable whose closed loop the exact analysis cannot confirm at some B):
        # not an answer, so nothing to check; counted apart with its rule
        return Outcome(case, "refused", seconds=time.perf_counter() - t0, verify_reason=f"{exc.field}: {exc.rule}")
    out = Outcome(case, d.status, seconds=time.perf_counter() - t0)
    bad = out.problems.append
    if d.status == "optimal":
        a = analyse_stability(dev, d.stiffness, d.damping)
        if a.stable is not True:
            bad(f"labelled optimal but the analysis says stable = {a.stable} (K = {d.stiffness!r}, "
                f"K_cr = {a.critical_stiffness!r})")
        if a.critical_stiffness is not None and d.critical_stiffness != a.critical_stiffness:
            bad(f"K_cr {d.critical_stiffness!r} differs from the analysis' {a.critical_stiffness!r}")
        if a.gain_margin_db is not None and not a.gain_margin_db >= req.min_gain_margin_db:
            bad(f"analysed margin {a.gain_margin_db!r} dB < required {req.min_gain_margin_db} dB")
        if req.passivity and a.passive is not True:
            bad(f"passivity required but the analysis says passive = {a.passive} (b = {dev.damping!r}, required "
                f"{a.passivity_required_damping!r})")
        for name, cap in req.stiffness_caps().items():
            if d.stiffness > cap:
                bad(f"K above {name}")
        for name, cap in req.damping_caps(dev.sample_time).items():
            if d.damping > cap:
                bad(f"B above {name}")
        at_cap = any(d.stiffness == cap for cap in req.stiffness_caps().values())
        if optimality and dev.delay_samples <= OPTIMALITY_MAX_DELAY:
            out.optimality_checked = True
            best = -math.inf if at_cap else scan_best(dev, req)[0]
            if math.isfinite(best) and d.stiffness < best * (1 - OPTIMALITY_RTOL):
                bad(f"labelled optimal with K = {d.stiffness!r} but the dense scan finds K = {best!r}")
        if verify:
            tv = time.perf_counter()
            v = verify_stiffness_design(dev, d.stiffness, d.damping, d.gain_margin_db,
                                        True if req.passivity else None)
            out.verify, out.verify_reason, out.verify_seconds = v.verdict, v.reason, time.perf_counter() - tv
            if v.verdict == "contradicted":
                bad(f"verify contradicts the design (K = {d.stiffness!r}, B = {d.damping!r}): {v.reason}")
    elif d.status == "infeasible":
        best, b = scan_best(dev, req)
        if best > 0:
            bad(f"labelled infeasible ({d.reason}) but the dense scan finds K = {best!r} at B = {b!r}")
    else:
        bad(f"failed: {d.reason}")
    return out
