"""Benchmark of the robust stiffness design: time and scenario count for 1, 2 and 4 uncertain parameters,
rigid and cable, with the nominal design of the same device timed side by side (ratio).

Writes docs/bench_robust.md.  Run:  PYTHONPATH=. python bench/bench_robust.py [--repeats N] [--quick]
BLAS is pinned to one thread (see bench/bench_stiffness.py for why).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models.device import Device  # noqa: E402
from optim.robust.box import UncertaintyBox  # noqa: E402
from optim.robust.stiffness import robust_design_stiffness  # noqa: E402
from optim.stiffness import StiffnessRequirements, design_stiffness  # noqa: E402

GOAL_MS = 1000.0        # issue 12: p50 ≤ 1 s for two uncertain parameters on a rigid device (2 cores)

_RIGID = {"preset": "lhifam", "cable": None}
_CABLE = {"preset": "lhifam"}
CASES = [
    ("rigid", 1, _RIGID, {"device.delay": (0.0, 0.002)}),
    ("rigid", 2, _RIGID, {"device.mass": (4.0, 7.0), "device.delay": (0.0, 0.002)}),
    ("rigid", 4, _RIGID, {"device.mass": (4.0, 7.0), "device.damping": (2.0, 5.0), "device.delay": (0.0, 0.0015),
                          "device.sample_time": (0.0008, 0.0012)}),
    ("cable", 1, _CABLE, {"device.cable.stiffness": (30000.0, 100000.0)}),
    ("cable", 2, _CABLE, {"device.cable.stiffness": (30000.0, 100000.0), "device.delay": (0.0, 0.002)}),
    ("cable", 4, _CABLE, {"device.cable.stiffness": (30000.0, 100000.0), "device.delay": (0.0, 0.002),
                          "device.cable.motor_mass": (0.2, 0.4), "device.cable.damping": (10.0, 20.0)}),
    # the box whose worst device is inside (tests/optim/robust): B ≤ 1e-3 N·s/m, two exchange rounds
    ("cable, B ≤ 1e-3", 2, _CABLE, {"device.cable.motor_mass": (0.1, 1.0), "device.cable.damping": (2.0, 40.0)}),
]
_CAPS = {"cable, B ≤ 1e-3": 1e-3}


def run(repeats: int, quick: bool) -> list[dict]:
    rows = []
    for kind, n, spec, ranges in (CASES[1:2] + CASES[3:4] if quick else CASES):
        req = StiffnessRequirements(max_damping=_CAPS.get(kind))
        dev = Device.model_validate(spec)
        box = UncertaintyBox.from_ranges(dev, ranges)
        t = time.perf_counter()
        first = robust_design_stiffness(dev, req, box)          # may build the scenario structures' solvers
        cold = (time.perf_counter() - t) * 1e3
        robust, nominal = [], []
        for _ in range(repeats):
            t = time.perf_counter()
            d = robust_design_stiffness(dev, req, box)
            robust.append((time.perf_counter() - t) * 1e3)
            t = time.perf_counter()
            design_stiffness(dev, req)
            nominal.append((time.perf_counter() - t) * 1e3)
        p50 = statistics.median(robust)
        rows.append({"kind": kind, "n": n, "paths": ", ".join(p.removeprefix("device.") for p in ranges),
                     "status": first.status, "stiffness": d.stiffness, "margin": d.gain_margin_db,
                     "scenarios": len(d.scenarios), "iterations": d.iterations, "evaluations": d.evaluations,
                     "cold_ms": cold, "p50": p50, "p95": float(np.percentile(robust, 95)),
                     "nominal_p50": statistics.median(nominal), "ratio": p50 / statistics.median(nominal)})
    return rows


def markdown(rows: list[dict], repeats: int) -> str:
    lines = ["# Robust stiffness design benchmark (`bench/bench_robust.py`)", "",
             f"{repeats} warm repeats per case after one cold call (which may build CasADi solvers); 6 dB gain "
             "margin, B free (except the last row), LHifAM. Comparator: the nominal design of the same device "
             "(optim.stiffness.design_stiffness), timed alternately in the same run. Scenarios = box points the "
             "NLP used (nominal + corners + added worst cases); evaluations = exact analyses spent by the "
             "worst-case searches. BLAS pinned to one thread.", "",
             "| model | uncertain | paths | status | K [N/m] | worst margin dB | scenarios | rounds | evaluations "
             "| cold ms | p50 ms | p95 ms | nominal p50 ms | robust/nominal |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['kind']} | {r['n']} | {r['paths']} | {r['status']} | {r['stiffness']:.6g} | "
                     f"{r['margin']:.7f} | {r['scenarios']} | {r['iterations']} | {r['evaluations']} | "
                     f"{r['cold_ms']:.0f} | {r['p50']:.0f} | {r['p95']:.0f} | {r['nominal_p50']:.1f} | "
                     f"{r['ratio']:.0f}× |")
    lines.append("")
    two = [r["p50"] for r in rows if r["kind"] == "rigid" and r["n"] == 2]
    if two:
        lines.append(f"- rigid, 2 uncertain parameters: p50 = {two[0]:.0f} ms (goal ≤ {GOAL_MS:.0f} ms)")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="two cases, for the test that keeps this from rotting")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "bench_robust.md"))
    args = ap.parse_args(argv)
    rows = run(args.repeats, args.quick)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(markdown(rows, args.repeats))
    return rows


if __name__ == "__main__":
    main()
