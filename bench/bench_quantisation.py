"""Encoder quantisation and Coulomb friction by simulation (issue 31); writes docs/quantisation_runs.md.

Three runs, each against zwidth's own predictions (optim.stability.nonlinear):

  * abbott: Abbott & Okamura's bound K ≤ min(2b/T, 2f_c/q) reproduced: on a grid of (m, b, f_c, q, T),
    K at 0.9× and 1.1× of each term, two energy audits (optim.nonlinear_verification.energy_audit): the
    chatter probe (a push held halfway between two encoder levels) and the instability probe (a deep push
    released in two samples); active below the bound is a failure, and the mode must be the paper's;
  * cycles: random quantised and/or Coulomb-damped walls (rigid and cable, 0-5 samples of delay, some with
    virtual damping): the describing function's regime and cycle against a long simulated release;
  * diolaiti: the regime in the (β, σ) = (b/(KT), f_c/(Kq)) plane for two delay slices, predicted and
    simulated.

Usage: PYTHONPATH=. python -m bench.bench_quantisation [--cycles 200] [--workers 2] [--seed 31]
       [--only abbott,cycles,diolaiti] [--out docs/quantisation_runs.md] [--quick]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from models.device import Device  # noqa: E402
from models.simulation.friction import FrictionEventLimit  # noqa: E402
from optim.nonlinear_verification import (  # noqa: E402
    AMPLITUDE_RTOL,
    CHATTER_COUNTS,
    FREQUENCY_RTOL,
    MeasuredCycle,
    energy_audit,
    measure_cycle,
    probe_forces,
    probe_hold,
    release_duration,
    release_start,
)
from optim.stability.margins import critical_stiffness  # noqa: E402
from optim.stability.nonlinear import analyse_nonlinear  # noqa: E402

# ---------------------------------------------------------------- Abbott & Okamura

#: (m [kg], T [s], b [N·s/m], f_c [N], q [m]): half with 2b/T binding, half with 2f_c/q binding
ABBOTT_POINTS = [
    (0.2, 1e-3, 0.5, 0.02, 1e-5), (0.2, 1e-3, 2.0, 0.002, 1e-5),
    (1.0, 1e-3, 1.0, 0.05, 1e-5), (1.0, 1e-3, 4.0, 0.005, 2e-5),
    (0.2, 5e-4, 0.3, 0.01, 5e-6), (0.2, 5e-4, 1.5, 0.001, 5e-6),
    (0.5, 2e-3, 2.0, 0.05, 2e-5), (0.5, 2e-3, 6.0, 0.002, 1e-5),
]


def abbott_case(args: tuple) -> dict:
    (m, t, b, f_c, q), term, factor = args
    dev = Device(mass=m, damping=b, sample_time=t, encoder_resolution=q, coulomb_friction=f_c)
    k_s, k_q = 2 * b / t, 2 * f_c / q
    k = factor * (k_s if term == "2b/T" else k_q)
    # the instability probe's depth: 10× the largest threshold predicted on this point's four walls
    ths = [analyse_nonlinear(dev, f * kk, 0.0).limit_cycle.threshold_amplitude
           for kk in (k_s, k_q) for f in (0.9, 1.1)]
    depth = 10 * max([x for x in ths if x is not None], default=50 * q)
    soft_f, _ = probe_forces(dev, k, None)
    soft = energy_audit(dev, k, 0.0, soft_f, ramp=0.2, hold=probe_hold(dev), free=0.2)
    hard = energy_audit(dev, k, 0.0, k * depth, ramp=0.02, hold=0.3, free=4.0)
    expected = {"instability"} if k > k_s else set()
    if k > k_q:
        expected |= {"chatter"}
    found = {a.mode for a in (soft, hard) if a.mode != "none"}
    return dict(m=m, t=t, b=b, f_c=f_c, q=q, term=term, factor=factor, k=k, bound=min(k_s, k_q), soft=soft, hard=hard,
                expected=expected, found=found, net=max(soft.net_energy, hard.net_energy),
                err=max(soft.error_bound, hard.error_bound))


def run_abbott(pool) -> list[dict]:
    cases = [(p, term, f) for p in ABBOTT_POINTS for term in ("2b/T", "2f_c/q") for f in (0.9, 1.1)]
    return list(pool.map(abbott_case, cases))


def abbott_table(rows: list[dict]) -> list[str]:
    out = ["| m | T | b | f_c | q | K = | K [N/m] | bound | net energy [J] | bound on its error [J] | "
           "chatter probe | instability probe | paper's mode | agrees |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        exp = "+".join(sorted(r["expected"])) or "passive"
        got = "+".join(sorted(r["found"])) or "passive"
        # where both modes are due, growth masks the chatter probe too (it grows instead of chattering)
        masked = r["expected"] == {"chatter", "instability"} and "instability" in r["found"] and \
            (r["soft"].mode == "instability" or (r["soft"].hold_motion_counts or 0) > CHATTER_COUNTS)
        found = r["found"] | ({"chatter"} if masked else set())
        ok = r["expected"] == found and (r["net"] <= 0) == (r["k"] <= r["bound"])
        r["ok"] = ok
        out.append(f"| {r['m']:g} | {r['t']:g} | {r['b']:g} | {r['f_c']:g} | {r['q']:g} | {r['factor']:g}·{r['term']} | "
                   f"{r['k']:.5g} | {r['bound']:.5g} | {r['net']:.3g} | {r['err']:.1g} | {r['soft'].mode} | "
                   f"{r['hard'].mode} | {exp} | {'yes' if ok else 'NO (' + got + ')'} |")
    return out

# ---------------------------------------------------------------- random limit cycles


@dataclass(frozen=True)
class CycleCase:
    device: Device
    stiffness: float
    damping: float
    kcr_factor: float


def random_wall(rng: np.random.Generator, cable: bool) -> CycleCase:
    t = 1e-3
    d = float(rng.integers(0, 6)) if rng.random() < 0.8 else float(rng.uniform(0, 5))   # 0-5 samples
    q = float(10 ** rng.uniform(-6, -4.3))
    kind = rng.choice(["both", "both", "quantisation", "friction"])
    if cable:
        # the LHifAM's cable scaled, its dampings raised 3-10× so that a release settles within ~30 s
        scale, damp = float(10 ** rng.uniform(-0.5, 0.5)), float(rng.uniform(3, 10))
        dev = Device(preset="lhifam", human=None, force_sensor=None, delay=d * t,
                     cable={"motor_mass": 0.3 * scale, "motor_damping": 0.1 * scale * damp, "body_mass": 5.1 * scale,
                            "body_damping": 3.4 * scale * damp, "stiffness": 79500.0 * scale,
                            "damping": 15.0 * scale})
        m, b = dev.mass, dev.damping
    else:
        m = float(10 ** rng.uniform(-1, 0.3))
        tau = float(10 ** rng.uniform(-1.3, -0.3))          # decay time 2m/b in 0.05-0.5 s
        b = 2 * m / tau
        dev = Device(mass=m, damping=b, sample_time=t, delay=d * t)
    damping = 0.0 if rng.random() < 0.75 else float(rng.uniform(0, 0.5)) * b
    kcr = critical_stiffness(dev, damping).critical_stiffness
    factor = float(rng.uniform(0.6, 1.3))
    k = factor * kcr
    f_c = None if kind == "quantisation" else float(10 ** rng.uniform(-1.5, 0.3)) * k * q / 2
    dev = dev.model_copy(update={"encoder_resolution": None if kind == "friction" else q, "coulomb_friction": f_c})
    if kind == "friction":   # a stick scale comparable to the quantised walls'
        dev = dev.model_copy(update={"coulomb_friction": float(10 ** rng.uniform(-1.5, 0.3)) * k * q / 2})
    return CycleCase(dev, k, damping, factor)


def cycle_case(case: CycleCase) -> dict:
    dev, k, bb = case.device, case.stiffness, case.damping
    t0 = time.perf_counter()
    nl = analyse_nonlinear(dev, k, bb)
    predict_ms = 1e3 * (time.perf_counter() - t0)
    start = release_start(dev, k, nl.limit_cycle)
    duration = release_duration(dev, k, bb, 3.0, 30.0)
    threshold_state = small_state = None
    try:
        meas = measure_cycle(dev, k, bb, start, duration)
        if meas.state == "decaying":   # a transient still dying out: run 3× longer before judging
            duration = min(3 * duration, 90.0)
            meas = measure_cycle(dev, k, bb, start, duration)
        th = nl.limit_cycle.threshold_amplitude
        if th is not None and 3 * th < start:   # the DF's growth threshold, checked apart from the regime
            threshold_state = measure_cycle(dev, k, bb, 3 * th, duration).state
        if th is not None and nl.limit_cycle.exists:   # a small cycle under the threshold, checked apart too
            small_state = measure_cycle(dev, k, bb, 1.5 * nl.limit_cycle.amplitude, duration).state
    except FrictionEventLimit:
        meas = MeasuredCycle("refused", math.nan, None, 0)
    expected = {"limit_cycle": "cycle", "unstable": "growing", "undetermined": "undetermined"}.get(nl.regime, "settled")
    agree = meas.state == expected
    a_err = f_err = None
    if agree and expected == "cycle":
        a_err = meas.amplitude / nl.limit_cycle.amplitude - 1
        f_err = None if meas.frequency_hz is None else meas.frequency_hz / nl.limit_cycle.frequency_hz - 1
    return dict(case=case, regime=nl.regime, expected=expected, measured=meas, agree=agree, start=start,
                predicted_a=nl.limit_cycle.amplitude, predicted_f=nl.limit_cycle.frequency_hz, a_err=a_err, f_err=f_err,
                threshold=nl.limit_cycle.threshold_amplitude, duration=duration, predict_ms=predict_ms,
                threshold_state=threshold_state, small_state=small_state, method=nl.limit_cycle.method.split(" (")[0])


def cause(r: dict) -> str:
    c, meas = r["case"], r["measured"]
    dev = c.device
    if r["regime"] == "undetermined":
        return "undetermined (counted apart)"
    if meas.state == "refused":
        return "the event integrator refused (more than 50 stick-slip events in one piece of a sample)"
    if meas.state == "decaying":
        return f"still decaying after {r['duration']:g} s (the loop's slowest mode; K/K_cr = {c.kcr_factor:.3f})"
    if r["expected"] == "cycle" and meas.state == "settled":
        return ("the describing function's cycle (A = {:.3g} counts) is not reached: the sampled staircase at a few "
                "counts is far from a sinusoid".format(r["predicted_a"] / dev.encoder_resolution)
                if dev.encoder_resolution else "predicted cycle not reached")
    if r["expected"] == "settled" and meas.state == "cycle":
        return (f"a cycle of {meas.amplitude:.3g} m at {meas.frequency_hz} Hz neither the orbit search nor the describing function finds "
                f"(K/K_cr = {c.kcr_factor:.3f}, σ = {(dev.coulomb_friction or 0) / (c.stiffness * (dev.encoder_resolution or 1)):.3g})")
    if r["expected"] == "growing":
        return (f"release from {r['start']:.3g} m (≥ 3× the predicted threshold {r['threshold']:.3g} m) did not grow "
                f"({meas.state})")
    return f"{r['expected']} predicted, {meas.state} measured"


def run_cycles(pool, n: int, seed: int) -> list[dict]:
    rng = np.random.default_rng(seed)
    cases = [random_wall(rng, cable=i % 4 == 3) for i in range(n)]
    return list(pool.map(cycle_case, cases, chunksize=2))


def cycles_table(rows: list[dict]) -> list[str]:
    n = len(rows)
    agree = sum(r["agree"] for r in rows)
    refused = sum(r["measured"].state == "refused" for r in rows)
    und = [r for r in rows if r["regime"] == "undetermined"]
    undetermined = len(und)
    checked = n - refused - sum(r["measured"].state != "refused" for r in und)
    smalls = [r for r in rows if r.get("small_state") is not None]
    ths = [r for r in rows if r.get("threshold_state") is not None]
    by_method: dict[str, list[dict]] = {}
    for r in rows:
        by_method.setdefault(r["method"], []).append(r)
    out = [f"{agree} of {checked} decided and checkable walls ({100 * agree / max(checked, 1):.1f} %) settle, cycle "
           f"or grow as predicted ({agree} of all {n}: {100 * agree / n:.1f} %); {refused} not checkable (the "
           f"simulator refused); {undetermined} of {n} ({100 * undetermined / n:.1f} %) answered undetermined "
           "(the simulation showed: " + (", ".join(f"{st} {sum(r['measured'].state == st for r in und)}"
                                                   for st in ("cycle", "settled", "decaying", "growing", "refused"))
                                         if und else "none") + ").", "",
           "Unstable walls with a stable cycle predicted under the growth threshold (a release from 1.5× the cycle): "
           + (", ".join(f"{st} {sum(r['small_state'] == st for r in smalls)}"
                        for st in ("cycle", "settled", "decaying", "growing")) if smalls else "none") + ".", "",
           "By the method that decided the cycle: " + "; ".join(
               f"{m}: {sum(r['agree'] for r in rs)}/{len(rs)} agree" for m, rs in sorted(by_method.items())) + ".", "",
           "The describing function's growth threshold, checked apart (a release from 3× it, where that is below the "
           f"regime's release): {sum(r['threshold_state'] == 'growing' for r in ths)} of {len(ths)} grew; the "
           "others: " + (", ".join(f"{st} {sum(r['threshold_state'] == st for r in ths)}"
                                   for st in ("cycle", "settled", "decaying")) if ths else "none") + ".", "",
           "| kind | walls | agree | predicted cycle | predicted unstable | predicted settled |", "|---|---|---|---|---|---|"]
    for label, sel in (("rigid", lambda r: r["case"].device.cable is None),
                       ("cable", lambda r: r["case"].device.cable is not None),
                       ("delay 0", lambda r: r["case"].device.delay == 0),
                       ("delay > 0", lambda r: r["case"].device.delay > 0),
                       ("B > 0", lambda r: r["case"].damping > 0),
                       ("all", lambda r: True)):
        rs = [r for r in rows if sel(r)]
        out.append(f"| {label} | {len(rs)} | {sum(r['agree'] for r in rs)} | "
                   + " | ".join(f"{sum(r['agree'] for r in rs if r['expected'] == e)}/"
                                f"{sum(r['expected'] == e for r in rs)}" for e in ("cycle", "growing", "settled")) + " |")
    errs = [r for r in rows if r["a_err"] is not None]
    if errs:
        ae = np.abs([r["a_err"] for r in errs])
        fe = np.abs([r["f_err"] for r in errs if r["f_err"] is not None])
        out += ["", f"Cycles both predicted and measured: {len(errs)}. |amplitude error|: median {np.median(ae):.2f}, "
                f"90th percentile {np.percentile(ae, 90):.2f}, max {ae.max():.2f}; within ±{AMPLITUDE_RTOL:g}: "
                f"{int(np.sum(ae <= AMPLITUDE_RTOL))}/{len(ae)}. |frequency error|: median "
                f"{np.median(fe) if fe.size else float('nan'):.3f}, max {fe.max() if fe.size else float('nan'):.3f}; "
                f"within ±{FREQUENCY_RTOL:g}: {int(np.sum(fe <= FREQUENCY_RTOL))}/{len(fe)}."]
    bad = [r for r in rows if not r["agree"] and r["regime"] != "undetermined"]
    listed = [("Every disagreement and its cause (the refused ones are not checkable, outside the rate):", bad),
              ("The walls answered undetermined, beside what the simulation showed:", und)]
    for title, sel in listed:
        out += ["", title, "",
                "| # | device | delay [samples] | K/K_cr | B | q | f_c | predicted | measured | cause |",
                "|---|---|---|---|---|---|---|---|---|---|"]
        out += _rows(sel)
    return out


def _rows(bad: list[dict]) -> list[str]:
    out = []
    for i, r in enumerate(bad):
        c = r["case"]
        dev = c.device
        out.append(f"| {i + 1} | {'cable' if dev.cable else 'rigid'} m={dev.mass:.3g} b={dev.damping:.3g} | "
                   f"{dev.delay_samples:.3g} | {c.kcr_factor:.3f} | {c.damping:.3g} | {dev.encoder_resolution} | "
                   f"{dev.coulomb_friction if dev.coulomb_friction is None else f'{dev.coulomb_friction:.3g}'} | "
                   f"{r['regime']} | {r['measured'].state} ({r['measured'].amplitude:.3g} m) | {cause(r)} |")
    return out

# ---------------------------------------------------------------- Diolaiti slices


DIOLAITI_BETAS = (0.1, 0.2, 0.3, 0.4, 0.45, 0.55, 0.7, 1.0, 1.6, 2.0)
DIOLAITI_SIGMAS = (0.0, 0.1, 0.3, 0.5, 1.0)


def diolaiti_case(args: tuple) -> dict:
    d, beta, sigma = args
    m, t, q = 0.2, 1e-3, 1e-5
    k = 1000.0
    b = beta * k * t
    f_c = sigma * k * q
    dev = Device(mass=m, damping=b, sample_time=t, delay=d * t, encoder_resolution=q,
                 coulomb_friction=f_c if f_c > 0 else None)
    nl = analyse_nonlinear(dev, k, 0.0)
    start = release_start(dev, k, nl.limit_cycle)
    duration = release_duration(dev, k, 0.0, 3.0, 15.0)
    small = None
    try:
        meas = measure_cycle(dev, k, 0.0, max(start, 20 * q), duration)
        th = nl.limit_cycle.threshold_amplitude
        if th is not None and f_c > 0:   # friction's hold on small motions: a release from 0.3× the threshold
            small = measure_cycle(dev, k, 0.0, 0.3 * th, duration).state
    except FrictionEventLimit:
        meas = MeasuredCycle("refused", math.nan, None, 0)
    return dict(d=d, beta=beta, sigma=sigma, regime=nl.regime, measured=meas.state, amp=meas.amplitude, small=small)


def run_diolaiti(pool) -> list[dict]:
    cases = [(d, be, si) for d in (0, 1) for be in DIOLAITI_BETAS for si in DIOLAITI_SIGMAS]
    return list(pool.map(diolaiti_case, cases))


_LETTER = {"passive": "P", "stable_not_passive": "S", "limit_cycle": "C", "unstable": "U"}
_MEAS = {"settled": "s", "cycle": "c", "growing": "u", "decaying": "d", "refused": "r"}


def diolaiti_table(rows: list[dict]) -> list[str]:
    out = []
    for d in (0, 1):
        out += ["", f"Slice d = {d} sample{'s' if d != 1 else ''} of delay (m = 0.2 kg, T = 1 ms, K = 1000 N/m, "
                "q = 10 µm; β = b/(KT), σ = f_c/(Kq)). Each cell: predicted regime (P passive, S stable not passive, "
                "C limit cycle, U unstable) / simulated release from the larger of 30× the growth threshold and 200 counts "
                "(U), 1.5× the cycle (C), or 20 counts "
                "(s settled, c cycle, u growing, d still decaying) / for U with friction, a release from 0.3× the "
                "threshold.", "",
                "| β \\ σ | " + " | ".join(f"{s:g}" for s in DIOLAITI_SIGMAS) + " |",
                "|---|" + "---|" * len(DIOLAITI_SIGMAS)]
        for be in DIOLAITI_BETAS:
            cells = []
            for si in DIOLAITI_SIGMAS:
                r = next(r for r in rows if r["d"] == d and r["beta"] == be and r["sigma"] == si)
                cells.append(f"{_LETTER[r['regime']]}/{_MEAS[r['measured']]}"
                             + (f"/{_MEAS[r['small']]}" if r.get("small") else ""))
            out.append(f"| {be:g} | " + " | ".join(cells) + " |")
    return out

# ---------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cycles", type=int, default=200)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--only", default="abbott,cycles,diolaiti")
    ap.add_argument("--out", default="docs/quantisation_runs.md")
    ap.add_argument("--quick", action="store_true", help="a few cases of each (the test's run)")
    a = ap.parse_args(argv)
    parts = set(a.only.split(","))
    lines = ["# Quantisation and Coulomb friction: the runs", "",
             f"Generated by `PYTHONPATH=. python -m bench.bench_quantisation` (seed {a.seed}). "
             "docs/quantisation.md explains the methods.", ""]
    started = time.perf_counter()
    with ProcessPoolExecutor(max_workers=a.workers) as pool:
        if "abbott" in parts:
            global ABBOTT_POINTS
            if a.quick:
                ABBOTT_POINTS = ABBOTT_POINTS[:2]
            t0 = time.perf_counter()
            rows = run_abbott(pool)
            table = abbott_table(rows)
            ok = sum(r["ok"] for r in rows)
            lines += ["## Abbott & Okamura's bound by simulation", "",
                      f"{ok} of {len(rows)} walls agree with the paper ({time.perf_counter() - t0:.0f} s).", "", *table, ""]
        if "cycles" in parts:
            t0 = time.perf_counter()
            rows = run_cycles(pool, 8 if a.quick else a.cycles, a.seed)
            lines += ["## Limit cycles on random walls", "",
                      f"{len(rows)} walls in {time.perf_counter() - t0:.0f} s; prediction median "
                      f"{np.median([r['predict_ms'] for r in rows]):.0f} ms.", "", *cycles_table(rows), ""]
        if "diolaiti" in parts:
            global DIOLAITI_BETAS, DIOLAITI_SIGMAS
            if a.quick:
                DIOLAITI_BETAS, DIOLAITI_SIGMAS = (0.3, 1.0), (0.0, 1.0)
            t0 = time.perf_counter()
            rows = run_diolaiti(pool)
            lines += ["## The (β, σ) plane (Diolaiti et al. 2006)", "",
                      f"{len(rows)} walls in {time.perf_counter() - t0:.0f} s.", *diolaiti_table(rows), ""]
    lines.append(f"Total wall time {time.perf_counter() - started:.0f} s.")
    Path(a.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
