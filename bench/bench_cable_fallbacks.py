"""Why the cable fast path falls back to the bounded scan (issue 32): the reasons, tabulated.

bench/bench_cable.py's draw (bench/bench_core.py's random damped cables, B = 0 / uniform below B_max / within
1e-4…1e-1 of it, a third each, the same devices and B for the same seed).  For each device that falls back on B_max
or K_cr: the reason, from optim.stability.cable_loop's ``last_reason`` (the factors not trusted) or the Python twin's
(optim.stability.cable_brackets ``last_reason``: budget, a piece too narrow, the polish) — debug labels, never in an
answer.  Prints the table (and, with --show, the first devices of each class).

    PYTHONPATH=. python -m bench.bench_cable_fallbacks [--cases 2000] [--seed 32]
"""

from __future__ import annotations

import argparse
import math
import re
import time
import warnings
from collections import Counter, defaultdict

import numpy as np


def _label(reason: str) -> str:
    return re.sub(r"[-+]?\d[\d.]*(e[-+]?\d+)?", "#", reason).replace("(gap #, err #, near #)", "at -1").replace(
        "(gap #, err #, )", "").strip()


def classify(cases: int, seed: int) -> tuple[Counter, Counter, dict]:
    from bench.bench_core import _random_cables
    from optim.stability import cable_brackets
    from optim.stability import cable_loop as cl
    from optim.stability.cable_kernel import cable_min_crossing_compiled
    from optim.stability.margins import NEAR_B_MAX, _cable_b_max, _theta_min, loop_plant, max_stable_damping

    devs = list(_random_cables(cases, np.random.default_rng(seed)))
    b_why: Counter = Counter()
    k_why: Counter = Counter()
    examples: dict = defaultdict(list)
    brng = np.random.default_rng([seed, 0])
    for i, dev in enumerate(devs):
        if i % 250 == 0:
            brng = np.random.default_rng([seed, i])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            plant = loop_plant(dev)
            bm = max_stable_damping(dev)
            kind = i % 3
            frac = brng.uniform(0, 1) if kind == 1 else 1 - 10 ** brng.uniform(-4, -1)
            b = 0.0 if kind == 0 or not math.isfinite(bm) else float(frac * bm)
            loop = cl.cable_loop(plant)
            loop_reason = "loop: " + _label(cl.last_reason[0]) if loop is None else None

            def why(beta: float, damper: bool, theta_lo: float) -> str | None:
                if loop is None:
                    return loop_reason
                got = cable_min_crossing_compiled(loop, beta, theta_lo, damper=damper)
                if got is not None and (got[0] is not None or beta == 0.0 and not damper):
                    return None
                if got is not None:
                    return "no crossover found (B > 0 or damper)"
                cable_brackets.last_reason[0] = "?"
                twin = cable_brackets.cable_min_crossing(loop, beta, theta_lo, damper=damper)
                return "brackets: " + (_label(cable_brackets.last_reason[0]) if twin is None else "twin differs")

            if _cable_b_max(dev, plant)[1] != "fast":
                rb = why(0.0, True, _theta_min(dev, 0.0)) or "?"
                b_why[rb] += 1
                examples["B " + rb].append((i, dev, b))
            r: str | None = None
            if b > 0.0 and b >= bm * (1.0 - NEAR_B_MAX):
                r = "near B_max"
            else:
                r = why(b / dev.damping_scale, False, _theta_min(dev, b / dev.damping_scale))
            if r is not None:
                k_why[r] += 1
                examples["K " + r].append((i, dev, b))
    return b_why, k_why, examples


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cases", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=32)
    ap.add_argument("--show", type=int, default=0)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    b_why, k_why, ex = classify(args.cases, args.seed)
    print(f"{args.cases} devices, seed {args.seed}, {time.perf_counter() - t0:.0f} s")
    print("| reason | B_max fallbacks | K_cr fallbacks |\n|---|---|---|")
    for r in sorted(set(b_why) | set(k_why), key=lambda r: -(b_why[r] + k_why[r])):
        print(f"| {r} | {b_why[r]} | {k_why[r]} |")
    print(f"| total | {sum(b_why.values())} | {sum(k_why.values())} |")
    for key, rows in ex.items():
        for i, dev, b in rows[:args.show]:
            print(key, i, b, dev.model_dump(exclude_none=True))


if __name__ == "__main__":
    main()
