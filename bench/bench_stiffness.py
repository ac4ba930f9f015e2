"""Benchmark of POST /v1/design/stiffness: time per design in-process and over HTTP, against a dense B scan.

Writes docs/bench_stiffness.md.  Run:  PYTHONPATH=. python bench/bench_stiffness.py [--repeats N] [--quick]

BLAS is single-threaded (models/__init__ limits it; the variables below make sure even before numpy loads):
the ZOH matrices are 5×5–8×8 matrix exponentials, and a multithreaded OpenBLAS on a shared 2-core machine
made each one ~15 ms instead of ~30 µs (measured here).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models.device import Device  # noqa: E402
from optim.stiffness import StiffnessRequirements, design_stiffness  # noqa: E402
from tests.optim.stiffness_scan import scan_best  # noqa: E402

GOALS_MS = {"rigid": 30.0, "cable": 80.0}


def cases(quick: bool) -> list[tuple[str, str, dict]]:
    lh = {"preset": "lhifam"}
    out = [("LHifAM rigid, no delay", "rigid", {**lh, "cable": None}),
           ("LHifAM rigid, 1.3 samples", "rigid", {**lh, "cable": None, "delay": 1.3e-3}),
           ("LHifAM rigid, 3 samples", "rigid", {**lh, "cable": None, "delay": 3e-3}),
           ("LHifAM cable, no delay", "cable", lh),
           ("LHifAM cable, 1.3 samples", "cable", {**lh, "delay": 1.3e-3}),
           ("PHANToM cable, 2 samples", "cable", {"preset": "phantom-1.0", "delay": 2e-3})]
    return [out[1], out[4]] if quick else out


def _pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q))


def run(repeats: int, quick: bool) -> list[dict]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from fastapi.testclient import TestClient
    from service.app import create_app
    client = TestClient(create_app())
    req = StiffnessRequirements()
    rows = []
    for name, kind, spec in cases(quick):
        device = Device.model_validate(spec)
        t = time.perf_counter()
        first = design_stiffness(device, req)              # may build this structure's solver
        cold = (time.perf_counter() - t) * 1e3
        total, setup, solve = [], [], []
        for _ in range(repeats):
            t = time.perf_counter()
            d = design_stiffness(device, req)
            total.append((time.perf_counter() - t) * 1e3)
            setup.append(d.setup_ms)
            solve.append(d.solve_ms)
        http = []
        for _ in range(repeats):
            t = time.perf_counter()
            r = client.post("/v1/design/stiffness", json={"device": spec, "requirements": {}})
            http.append((time.perf_counter() - t) * 1e3)
            assert r.status_code == 200 and r.json()["status"] == "optimal"
        t = time.perf_counter()
        k_scan, _ = scan_best(device, req, points=61 if quick else 121)
        scan_ms = (time.perf_counter() - t) * 1e3
        rows.append({"case": name, "kind": kind, "status": first.status, "cold_ms": cold,
                     "p50": statistics.median(total), "p95": _pct(total, 95),
                     "setup_p50": statistics.median(setup), "solve_p50": statistics.median(solve),
                     "http_p50": statistics.median(http), "http_p95": _pct(http, 95),
                     "scan_ms": scan_ms, "ratio": scan_ms / statistics.median(total),
                     "rel_diff": (d.stiffness - k_scan) / k_scan, "stiffness": d.stiffness})
    return rows


def markdown(rows: list[dict], repeats: int) -> str:
    lines = ["# Stiffness design benchmark (`bench/bench_stiffness.py`)", "",
             f"{repeats} warm repeats per case after one cold call (which may build the case's CasADi solver); "
             "6 dB gain margin, B free. Comparator: a dense scan of B with the exact K_cr at every point and "
             "bounded refinement of the three best (tests/optim/stiffness_scan.py), timed in the same run. "
             "BLAS pinned to one thread.", "",
             "| case | status | K [N/m] | cold ms | p50 ms | p95 ms | setup p50 | solve p50 | HTTP p50 | HTTP p95 "
             "| scan ms | scan/design | (K − K_scan)/K_scan |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['status']} | {r['stiffness']:.6g} | {r['cold_ms']:.0f} | {r['p50']:.1f} | "
                     f"{r['p95']:.1f} | {r['setup_p50']:.1f} | {r['solve_p50']:.1f} | {r['http_p50']:.1f} | "
                     f"{r['http_p95']:.1f} | {r['scan_ms']:.0f} | {r['ratio']:.1f}× | {r['rel_diff']:.1e} |")
    lines.append("")
    for kind, goal in GOALS_MS.items():
        p50s = [r["p50"] for r in rows if r["kind"] == kind]
        if p50s:
            lines.append(f"- {kind}: median of the cases' p50 = {statistics.median(p50s):.1f} ms (goal ≤ {goal:.0f} ms)")
    lines.append("- setup = boundary sampling, B_max and the coarse profile; solve = NLP solves, exact re-checks "
                 "(critical_stiffness at the chosen B) and sensitivities.")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--quick", action="store_true", help="two cases, for the test that keeps this from rotting")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "bench_stiffness.md"))
    args = ap.parse_args(argv)
    rows = run(args.repeats, args.quick)
    text = markdown(rows, args.repeats)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)
    print(text)
    for r in rows:
        print(f"{r['case']}: dense scan / design = {r['ratio']:.1f}")
    return rows


if __name__ == "__main__":
    main()
