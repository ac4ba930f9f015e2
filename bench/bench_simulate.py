"""Cost of a simulated scene against the effects it names; writes docs/bench_simulate.md.

Scenes: the LHifAM (chapter Table 2) released from 1 mm into a wall at half its K_cr, T = 1 ms.
Each row adds one effect to the row above and reports the marginal cost.  Comparators run
side by side in the same process: solve_ivp (DOP853, rtol 1e-10) integrating the same sampled loop
between samples, and the exact per-sample loop (models.simulation.sim_loop.run_sampled_loop) on the linear scene.
The solve_ivp comparator runs 1 s of the scene (it costs ~1 ms per sample); its per-sample cost is
scaled to the row's length and the table says so.

Usage: PYTHONPATH=. python bench/bench_simulate.py [--quick] [--out docs/bench_simulate.md]
"""

from __future__ import annotations

import os

# Small matrices (≤ 12×12): multi-threaded OpenBLAS only adds synchronisation, and on a loaded
# 2-core machine it was measured at ~10 ms per 4×4 expm instead of 0.06 ms.  Set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.sim_loop import linear_step, run_sampled_loop
from models.simulation.simulate import loop_spec, simulate

TARGET_MS = 20.0       # issue 13: 10 s of a 1 kHz linear scene in ≤ 20 ms

ROWS = [
    ("linear: zoh + sampling", {}),
    ("+ delay (1.5 ms, fractional)", {"delay": {}}),
    ("+ cable_mode", {"delay": {}, "cable_mode": {}}),
    ("+ human", {"delay": {}, "cable_mode": {}, "human": {}}),
    ("+ force_sensor_filter + force_feedforward", {"delay": {}, "cable_mode": {}, "human": {},
                                                   "force_sensor_filter": {},
                                                   "force_feedforward": {"gain": 1.0, "cutoff_hz": 20.0}}),
    ("+ quantization (sampled loop)", {"delay": {}, "cable_mode": {}, "human": {}, "quantization": {"resolution": 3.14e-6}}),
    ("+ saturation", {"delay": {}, "cable_mode": {}, "human": {}, "quantization": {"resolution": 3.14e-6},
                      "saturation": {"max_force": 20.0}}),
    ("+ coulomb_friction (event integrator)", {"delay": {}, "cable_mode": {}, "human": {},
                                               "quantization": {"resolution": 3.14e-6},
                                               "saturation": {"max_force": 20.0},
                                               "coulomb_friction": {"force": 0.5}}),
]


def _timed(fn, repeats: int) -> tuple[float, float]:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(1e3 * (time.perf_counter() - t0))
    times.sort()
    return statistics.median(times), times[min(len(times) - 1, int(round(0.95 * (len(times) - 1))))]


def _ode_comparator(dev: Device, k: float, seconds: float) -> float:
    """ms for `seconds` of the rigid release with solve_ivp between samples (no delay)."""
    m, b, t_s = dev.mass, dev.damping, dev.sample_time
    n = int(round(seconds / t_s))

    def rhs(_t, s, u):
        return [s[1], (u - b * s[1]) / m]
    t0 = time.perf_counter()
    state = np.array([1e-3, 0.0])
    for kk in range(n):
        u = -k * state[0]
        state = solve_ivp(rhs, (kk * t_s, (kk + 1) * t_s), state, args=(u,), method="DOP853",
                          rtol=1e-10, atol=1e-15).y[:, -1]
    return 1e3 * (time.perf_counter() - t0)


def run(quick: bool) -> str:
    dev = Device(preset="lhifam", delay=0.0015)
    seconds = 0.5 if quick else 10.0
    repeats = 3 if quick else 15
    k = 0.5 * 1024.0                                   # half the K_cr of the cable loop with 1.5 ms … stable
    lines = ["# bench_simulate: cost of a scene against the effects it names", "",
             f"{seconds:g} s of the LHifAM at 1 kHz ({int(seconds * 1000)} samples), released from 1 mm, K = {k:g} N/m. "
             "Each row adds one effect; marginal = this row's median minus the previous row's. "
             f"BLAS threads: OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}.", "",
             "| scene | method | median [ms] | p95 [ms] | marginal [ms] | µs/sample |",
             "|---|---|---|---|---|---|"]
    prev = None
    base_median = None
    warm = Scene(experiment="release", duration=seconds, controller={"stiffness": k}, initial={"position": 1e-3})
    for _ in range(5):                                 # FFT plans, expm code paths, allocator
        simulate(dev, warm)
    for name, eff in ROWS:
        scene = Scene(experiment="release", duration=seconds, controller={"stiffness": k},
                      initial={"position": 1e-3}, effects=eff)
        reps = max(2, repeats // 5) if "coulomb" in name else repeats
        res = simulate(dev, scene)
        med, p95 = _timed(lambda: simulate(dev, scene), reps)
        base_median = med if base_median is None else base_median
        marginal = "" if prev is None else f"{med - prev:+.2f}"
        lines.append(f"| {name} | {res.method} | {med:.2f} | {p95:.2f} | {marginal} | {1e3 * med / res.samples:.2f} |")
        prev = med
    # comparators on the first (linear rigid) row
    scene = Scene(experiment="release", duration=seconds, controller={"stiffness": k}, initial={"position": 1e-3})
    rigid = dev.rigid()
    spec = loop_spec(rigid, scene)
    n = int(round(seconds / rigid.sample_time))
    x0 = np.array([1e-3, 0.0])
    loop_med, loop_p95 = _timed(lambda: run_sampled_loop(spec, x0, 0.0, np.zeros(n), n, linear_step(spec.sampled)),
                                max(3, repeats // 3))
    lin_med, lin_p95 = _timed(lambda: simulate(rigid, scene), repeats)
    ode_seconds = min(seconds, 0.2 if quick else 1.0)
    ode_ms = _ode_comparator(rigid, k, ode_seconds) * seconds / ode_seconds
    lines += ["", "## Comparators (same run, rigid linear scene)", "",
              "| propagation | median [ms] | p95 [ms] | ratio to exact-linear-recursion |", "|---|---|---|---|",
              f"| exact-linear-recursion (block powers, models/simulation/propagate.py) | {lin_med:.2f} | {lin_p95:.2f} | 1 |",
              f"| exact per-sample Python loop (models/simulation/sim_loop.py) | {loop_med:.2f} | {loop_p95:.2f} | {loop_med / lin_med:.0f}× |",
              f"| solve_ivp DOP853 per sample (measured on {ode_seconds:g} s, scaled ×{seconds / ode_seconds:g}) | "
              f"{ode_ms:.0f} | – | {ode_ms / lin_med:.0f}× |", "",
              f"Target (issue 13): 10 s of a 1 kHz linear scene in ≤ {TARGET_MS:g} ms — "
              f"{'met' if lin_med * 10.0 / seconds <= TARGET_MS else 'NOT met'} "
              f"({lin_med * 10.0 / seconds:.2f} ms per 10 s{' extrapolated from the quick run' if quick else ''}).", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "docs" / "bench_simulate.md"))
    args = ap.parse_args(argv)
    text = run(args.quick)
    Path(args.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
