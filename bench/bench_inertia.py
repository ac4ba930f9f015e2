"""Benchmark: time per inertia design (K_f and filter cutoff), rigid and cable LHifAM.

Writes docs/bench_inertia.md: median and p95 per design of ``optim.transparency.inertia.design_inertia``
(exact Pareto scan with its jumps bracketed + CasADi crossover NLP + exchange + exact re-check), and side by side in
the same run a dense-scan comparator (the exact K_f,cr at 200 cutoffs, best grid point),
with the time ratio and how far the comparator's answer is from the design's.

Run:  PYTHONPATH=. python bench/bench_inertia.py [--repeats N]

BLAS threads: OpenBLAS's threaded kernels make scipy's expm of a 5×5 matrix cost ~12 ms
instead of ~20 µs on a loaded 2-core machine (measured here), so the benchmark pins one
thread unless the caller set it; the table records the setting.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from models.device import Device  # noqa: E402
from models.feedforward import feedforward_plant  # noqa: E402
from optim.transparency.feedforward import critical_force_gain_of_plant  # noqa: E402
from optim.transparency.inertia import InertiaRequirements, design_inertia  # noqa: E402

HUMAN = {"mass": 2.0, "damping": 2.0, "stiffness": 10.0}
SENSOR = {"time_constant": 0.005}
CASES = {
    "rigid, min apparent mass": (Device(mass=5.4, damping=3.5, sample_time=1e-3, human=HUMAN, force_sensor=SENSOR),
                                 InertiaRequirements()),
    "cable, min apparent mass": (Device(preset="lhifam"), InertiaRequirements()),
    "rigid, target 0.9 kg": (Device(mass=5.4, damping=3.5, sample_time=1e-3, human=HUMAN, force_sensor=SENSOR),
                             InertiaRequirements(target_apparent_mass=0.9)),
    "cable, target 0.9 kg": (Device(preset="lhifam"), InertiaRequirements(target_apparent_mass=0.9)),
    "cable, 4th order, interior optimum": (Device(preset="lhifam"),
                                           InertiaRequirements(filter_order=4, cutoff_min_hz=20.0)),
    # tests/optim/transparency/test_inertia_band.py: the maximum sits just past a jump of K_f,cr (issue 17)
    "cable, 3rd order, optimum at a jump": (Device(
        sample_time=0.001, delay=0.005, cable={"motor_mass": 0.13083075775577963, "motor_damping": 0.1,
                                               "body_mass": 1.2976995679619583, "body_damping": 3.4,
                                               "stiffness": 40337.893360381364, "damping": 3.670580004984369},
        human={"mass": 0.3249975817141055, "damping": 0.8204500601562204, "stiffness": 207.4975656200832},
        force_sensor={"time_constant": 0.0}), InertiaRequirements(filter_order=3)),
}
DENSE_POINTS = 200
GOAL_P50_MS = 80.0


def dense_scan_design(device: Device, req: InertiaRequirements, band: tuple[float, float],
                      points: int = DENSE_POINTS) -> tuple[float, float]:
    """Comparator: exact K_f,cr on a dense cutoff grid; (K_f, cutoff) of the best grid point."""
    plant = feedforward_plant(device, device.human)
    rho = 10 ** (req.min_gain_margin_db / 20)
    cutoffs = np.geomspace(*band, points)
    kcr = np.array([critical_force_gain_of_plant(plant, 2 * math.pi * c * device.sample_time,
                                                 req.filter_order)[0] for c in cutoffs])
    if req.target_apparent_mass is None:
        j = int(np.argmax(kcr))
        return float(kcr[j] / rho), float(cutoffs[j])
    kf = device.mass / req.target_apparent_mass - 1
    ok = np.nonzero(kcr >= rho * kf)[0]
    return (kf, float(cutoffs[ok[-1]])) if ok.size else (math.nan, math.nan)


def _stats(ts: list[float]) -> tuple[float, float]:
    a = np.array(ts) * 1e3
    return float(np.median(a)), float(np.percentile(a, 95))


def run(repeats: int = 15, comparator_repeats: int = 3, out: Path | None = Path("docs/bench_inertia.md"),
        dense_points: int = DENSE_POINTS) -> list[dict]:
    rows = []
    for name, (dev, req) in CASES.items():
        t0 = time.perf_counter()
        first = design_inertia(dev, req)                         # builds (and caches) the CasADi solver
        first_ms = (time.perf_counter() - t0) * 1e3
        ts = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            d = design_inertia(dev, req)
            ts.append(time.perf_counter() - t0)
        cs = []
        for _ in range(comparator_repeats):
            t0 = time.perf_counter()
            kf_dense, fc_dense = dense_scan_design(dev, req, first.cutoff_band_hz, dense_points)
            cs.append(time.perf_counter() - t0)
        p50, p95 = _stats(ts)
        c50, c95 = _stats(cs)
        rows.append(dict(case=name, status=d.status, force_gain=d.force_gain, cutoff=d.filter_cutoff_hz,
                         margin=d.gain_margin_db, p50=p50, p95=p95, first=first_ms, c50=c50, c95=c95,
                         ratio=c50 / p50, kf_dense=kf_dense, fc_dense=fc_dense))
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(_table(rows, repeats, comparator_repeats))
    return rows


def _table(rows: list[dict], repeats: int, comparator_repeats: int) -> str:
    lines = [
        "# Inertia design benchmark (bench/bench_inertia.py)",
        "",
        f"In-process time per `design_inertia` call ({repeats} runs after one warm-up that builds the CasADi",
        f"solver), against a dense-scan comparator measured in the same run ({comparator_repeats} runs): exact",
        f"K_f,cr at {DENSE_POINTS} geometric cutoffs over the same band, best grid point. Goal: p50 ≤ {GOAL_P50_MS:g} ms.",
        "Defaults: 6 dB, band [10 Hz, first cable mode or 0.4 × Nyquist], 2nd-order Butterworth, 17-point",
        "Pareto curve included in every design; rigid-model comparison included for cable devices.",
        "",
        f"Machine: {platform.machine()}, {os.cpu_count()} cores shared with other jobs; Python {platform.python_version()};"
        f" OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')};"
        f" load average at the end {os.getloadavg()[0]:.2f}.",
        "",
        "| case | status | K_f | cutoff [Hz] | margin [dB] | p50 [ms] | p95 [ms] | first call [ms] "
        "| dense scan p50 [ms] | p95 [ms] | time ratio (dense/design) | dense K_f | K_f design/dense − 1 "
        "| dense cutoff [Hz] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['case']} | {r['status']} | {r['force_gain']:.6g} | {r['cutoff']:.6g} | {r['margin']:.6f} "
                     f"| {r['p50']:.1f} | {r['p95']:.1f} | {r['first']:.1f} | {r['c50']:.1f} | {r['c95']:.1f} "
                     f"| {r['ratio']:.2f} | {r['kf_dense']:.6g} | {r['force_gain'] / r['kf_dense'] - 1:.2e} "
                     f"| {r['fc_dense']:.6g} |")
    lines += ["", "The design's K_f is never below the dense scan's (it refines the best bracket to full precision); "
              "in target mode the design's cutoff is the exact boundary, the scan's the last feasible grid point.", ""]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--comparator-repeats", type=int, default=3)
    args = ap.parse_args()
    for r in run(args.repeats, args.comparator_repeats):
        print(f"{r['case']:40s} p50 {r['p50']:7.1f} ms  p95 {r['p95']:7.1f} ms  dense {r['c50']:7.1f} ms  "
              f"ratio {r['ratio']:.2f}")


if __name__ == "__main__":
    main()
