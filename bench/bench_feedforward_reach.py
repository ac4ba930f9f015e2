"""The cost of the force-feedforward count's mpmath look (verify's _ff_point past 160 states): the two counts at
K_f,cr·(1 ± 1e-6) on issue 34's cable with the chapter's grasp (170 states), with the mpmath reach check and with
double precision alone, in the same run (median and p95 of CPU time; the mpmath plant is built in each repetition).

Usage:  PYTHONPATH=. python -m bench.bench_feedforward_reach [--reps 15]
Prints a markdown table (the numbers docs/verification.md quotes) with the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from models.device import Device
from models.filters import ButterworthLowPass
from optim.stability.closed_loop_mp import PRECISE_DIGITS
from optim.transparency.closed_loop_feedforward import feedforward_loop, feedforward_unstable_count
from optim.transparency.feedforward_ladder import analyse_force_feedforward
from tests.optim.test_verification_feedforward_reach import CABLE, CUTOFF, ORDER


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=15)
    args = ap.parse_args()
    dev = Device.model_validate(CABLE)
    a = analyse_force_feedforward(dev, ButterworthLowPass(ORDER, CUTOFF, dev.sample_time))
    k = a.critical_force_gain
    times: dict[int | None, list[float]] = {None: [], PRECISE_DIGITS: []}
    counts: dict[int | None, tuple] = {}
    load0 = os.getloadavg()[0]
    for _ in range(args.reps):
        for digits in (None, PRECISE_DIGITS):           # interleaved: the same load for both
            loop = feedforward_loop(dev, a.human, ORDER, CUTOFF)
            t0 = time.process_time()
            counts[digits] = tuple(feedforward_unstable_count(loop, k * f, digits).count for f in (1 - 1e-6, 1 + 1e-6))
            times[digits].append(time.process_time() - t0)
    load1 = os.getloadavg()[0]
    print(f"| counts at K_f,cr·(1 ± 1e-6), {loop.states} states | median CPU [ms] | p95 CPU [ms] | poles outside |")
    print("|---|---|---|---|")
    for digits, name in ((None, "double precision alone"), (PRECISE_DIGITS, "with the 50-digit mpmath look")):
        v = np.array(times[digits]) * 1e3
        print(f"| {name} | {statistics.median(v):.1f} | {np.percentile(v, 95):.1f} | {counts[digits]} |")
    ratio = statistics.median(times[PRECISE_DIGITS]) / statistics.median(times[None])
    print(f"\nsame-run ratio {ratio:.2f}×, {args.reps} repetitions, load average {load0:.1f} → {load1:.1f}")


if __name__ == "__main__":
    main()
