"""Property run of the robust design of a rendered wall (optim.robust.rendered_stiffness, issue 30).

Random rigid devices and boxes (mass × damping × delay, sometimes the sample time), random velocity filters (low-pass
order 1 or 2, moving average) and virtual masses of either sign; each optimal design is checked independently:

* a 5×5×5 grid over the box (the uncertain axes) by the exact rendered analysis: its smallest margin must meet the
  requirement (within 1e-6 dB);
* the closed loop with the filter's and the virtual mass's states at every grid device (optim.verification with the
  rendered loop: eigenvalues, the argument principle where they do not decide): K stable, and that device's rendered
  K_cr confirmed at K_cr·(1 ∓ 1e-6);
* verify (optim.verification_robust with the rendered loop): every corner, the worst device and the independent
  interior search, confirmed.

Writes docs/properties_robust_rendered.md.

    PYTHONPATH=. python -m bench.robust_rendered_properties [cases]
"""

from __future__ import annotations

import itertools
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from models.device import Device
from models.velocity_filter import LowPass, MovingAverage, rendering
from optim.errors import InputError
from optim.robust.box import UncertaintyBox
from optim.robust.rendered_stiffness import robust_rendered_stiffness
from optim.stability.rendered import rendered_critical_stiffness
from optim.stiffness import StiffnessRequirements
from optim.verification import verify_stiffness_design
from optim.verification_robust import verify_robust_stiffness

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _case(rng: np.random.Generator):
    t = float(rng.choice([0.0005, 0.001, 0.002]))
    m = float(rng.uniform(0.2, 8.0))
    b = float(rng.uniform(0.2, 10.0))
    td = float(rng.uniform(0.0, 3.0)) * t
    dev = Device(mass=m, damping=b, sample_time=t, delay=td)
    w = float(rng.uniform(0.05, 0.3))
    ranges = {"device.mass": (m * (1 - w), m * (1 + w)), "device.damping": (b * (1 - w), b * (1 + w)),
              "device.delay": (td * (1 - w), td * (1 + w) + 0.2 * t)}
    if rng.random() < 0.25:
        ranges["device.sample_time"] = (t, t * (1 + w))
    kind = rng.integers(3)
    nyq = 0.5 / (t * (1 + w))
    if kind == 0:
        spec = LowPass(kind="low_pass", cutoff_hz=float(nyq * rng.uniform(0.02, 0.5)), order=1)
    elif kind == 1:
        spec = LowPass(kind="low_pass", cutoff_hz=float(nyq * rng.uniform(0.02, 0.5)), order=2)
    else:
        spec = MovingAverage(kind="moving_average", samples=int(rng.integers(1, 6)))
    mass = float(rng.choice([0.0, 0.0, rng.uniform(-0.5, 0.5) * m]))
    gm = float(rng.choice([3.0, 6.0, 10.0]))
    return dev, ranges, spec, mass, gm


def _check(dev, ranges, spec, mass, gm, d) -> tuple[float, int, str]:
    box = UncertaintyBox.from_ranges(dev, ranges)
    axes = [np.linspace(lo, hi, 5) for lo, hi in zip(box.lower, box.upper)]
    worst, unstable = math.inf, 0
    for x in itertools.product(*axes):
        dv = box.device_at(np.array(x))
        r = rendering(spec, mass, dv.sample_time)
        kcr = rendered_critical_stiffness(dv, d.damping, r).critical_stiffness
        worst = min(worst, 20 * math.log10(kcr / d.stiffness) if kcr > 0 else -math.inf)
        # the closed loop with the filter's states (eigenvalues, else the argument principle): K stable, K_cr ± 1e-6
        v = verify_stiffness_design(dv, d.stiffness, d.damping, None, None, critical=kcr, render=(spec, mass))
        unstable += 0 if v.verdict == "confirmed" else 1
    v = verify_robust_stiffness(box, d.stiffness, d.damping, gm, False, d.worst_case["device"], None, (spec, mass))
    return worst, unstable, v.verdict


def main(cases: int = 30) -> None:
    rng = np.random.default_rng(20261203)
    rows, counts = [], {"optimal": 0, "infeasible": 0, "failed": 0, "refused": 0}
    bad = 0
    t0 = time.perf_counter()
    for i in range(cases):
        dev, ranges, spec, mass, gm = _case(rng)
        label = (f"low-pass {spec.cutoff_hz:.4g} Hz o{spec.order}" if isinstance(spec, LowPass)
                 else f"moving average {spec.samples}") + (f", M = {mass:.3g}" if mass else "")
        try:
            box = UncertaintyBox.from_ranges(dev, ranges)
            s = time.perf_counter()
            d = robust_rendered_stiffness(dev, StiffnessRequirements(min_gain_margin_db=gm), box, mass, spec)
            el = time.perf_counter() - s
        except InputError as exc:
            counts["refused"] += 1
            rows.append(f"| {i} | {label} | refused: {exc.field} | | | | | |")
            continue
        counts[d.status] += 1
        if d.status != "optimal":
            rows.append(f"| {i} | {label} | {d.status}: {d.reason} | | | | | |")
            continue
        worst, unstable, verdict = _check(dev, ranges, spec, mass, gm, d)
        ok = worst >= gm - 1e-6 and unstable == 0 and verdict == "confirmed"
        bad += 0 if ok else 1
        rows.append(f"| {i} | {label} | optimal, {len(ranges)} paths | {gm:g} | {d.gain_margin_db:.9g} | "
                    f"{worst:.9g} | {unstable} | {verdict} ({el:.2f} s) |")
    lines = [
        "# Property run: the robust design of a rendered wall",
        "",
        "Generated by `bench/robust_rendered_properties.py` (module doc: what is checked and how).  "
        f"{cases} random rigid devices and boxes (mass, damping, delay ± 5–30 %, a quarter with the sample time too), "
        "random low-pass (order 1 or 2) or moving-average filters and virtual masses of either sign; each optimal "
        "design checked on a 5×5×5 grid of its box by the exact rendered analysis (grid margin) and by the closed loop "
        "with the filter's states (devices where K is not stable or K_cr·(1 ∓ 1e-6) is not confirmed), and by verify "
        "(corners, worst device, interior search).",
        "",
        f"Outcome: {counts['optimal']} optimal, {counts['infeasible']} infeasible, {counts['failed']} failed, "
        f"{counts['refused']} refused; **{bad} contradicted** (grid margin short, a grid device unstable, or verify "
        f"not confirmed).  {time.perf_counter() - t0:.0f} s in all (load {os.getloadavg()[0]:.1f} on 2 shared "
        "cores).",
        "",
        "| case | velocity | outcome | GM [dB] | design's worst margin [dB] | grid margin [dB] | grid devices not "
        "confirmed | verify |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
        "",
    ]
    (DOCS / "properties_robust_rendered.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 30)
