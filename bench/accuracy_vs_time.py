"""What accuracy costs in time: every rung of the ladder and python-control on one fixed suite.

For each case the truth is the ``reference`` rung (40-digit mpmath).  Each rung
(``linear``, ``grid``, ``exact``, ``reference``) and python-control's
``stability_margins`` (default, and the minimum of ``returnall``) is timed on the
same system; the table gives median and p95 time, the median and maximum relative
error, the number of answers wrong by more than 1 %, and the first case (in the
suite's order of difficulty) where each becomes wrong.  Writes docs/accuracy.md
and docs/accuracy.png.

    python -m bench.accuracy_vs_time [--quick] [--repeats N]

A second table does the same for the force-feedforward loop (K_f,cr, chapter §5).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import platform
import statistics
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from models.device import Device
from optim.stability.analysis import analyse_stability
from optim.verification import verify_analysis, verify_force_feedforward

RUNGS = ("linear", "grid", "exact", "reference")
EXPERIMENT = "experiment (relay, 3 starts)"
#: cases where a lab would run the relay experiment of §4.4 (translational devices, no virtual damping)
EXPERIMENT_CASES = ("LHifAM rigid d=0", "LHifAM rigid d=5", "LHifAM cable d=0", "LHifAM cable d=3")
PEERS = ("python-control default", "python-control min(returnall)")


def _rigid(delta: float, d: float, t: float = 1e-3, m: float = 1.0) -> dict:
    return {"mass": m, "damping": delta * m / t, "sample_time": t, "delay": d * t}


def suite() -> list[tuple[str, dict, float]]:
    """(name, device kwargs, B as a fraction of B_max) ordered roughly by difficulty."""
    cases: list[tuple[str, dict, float]] = []
    for d in (0, 1, 5, 50, 200):
        cases.append((f"LHifAM rigid d={d}", {"mass": 5.4, "damping": 3.5, "delay": d * 1e-3}, 0.0))
    for d in (0.5, 2.25, 3 - 1e-6, 3 + 1e-6, 17.5):
        cases.append((f"LHifAM rigid d={d:.7g}", {"mass": 5.4, "damping": 3.5, "delay": d * 1e-3}, 0.0))
    for delta in (1e-3, 1e-6, 1e-9, 1e-12):
        for d in (0, 20, 200):
            cases.append((f"rigid δ={delta:g} d={d}", _rigid(delta, d), 0.0))
    for frac in (0.05, 0.2, 0.4, 0.6, 0.8):
        cases.append((f"LHifAM rigid d=5 B={frac:g}·B_max", {"mass": 5.4, "damping": 3.5, "delay": 5e-3}, frac))
    for frac in (0.1, 0.5):
        cases.append((f"DLR-like d=55 B={frac:g}·B_max", {"mass": 0.8, "damping": 0.5, "delay": 0.055}, frac))
    for d in (0, 1, 3, 5, 50, 200):
        cases.append((f"LHifAM cable d={d}", {"preset": "lhifam", "delay": d * 1e-3}, 0.0))
    cases.append(("LHifAM cable d=2.5", {"preset": "lhifam", "delay": 2.5e-3}, 0.0))
    cases.append(("LHifAM cable d=1 B=0.3·B_max", {"preset": "lhifam", "delay": 1e-3}, 0.3))
    cases.append(("reduced pretension d=0", {"preset": "lhifam-reduced-pretension"}, 0.0))
    cases.append(("reduced pretension d=3", {"preset": "lhifam-reduced-pretension", "delay": 3e-3}, 0.0))
    cases.append(("PHANToM cable d=0", {"preset": "phantom-1.0"}, 0.0))
    cases.append(("PHANToM cable d=1.7", {"preset": "phantom-1.0", "delay": 1.7e-3}, 0.0))
    cases.append(("LHifAM cable undamped d=1", {"preset": "lhifam", "delay": 1e-3, "cable": {"damping": 0.0}}, 0.0))
    cases.append(("LHifAM cable T=10µs d=10", {"preset": "lhifam", "sample_time": 1e-5, "delay": 1e-4}, 0.0))
    return cases


_FF_HUMAN = {"mass": 2.0, "damping": 2.0, "stiffness": 10.0}     # eq. 30
_FF_SENSOR = {"time_constant": 0.005}                              # eq. 31


def feedforward_suite() -> list[tuple[str, dict, tuple[float, int] | None]]:
    """(name, device kwargs, filter (cutoff Hz, order) or None): LHifAM rigid and cable, with and without the
    chapter's 2nd-order 30 Hz Butterworth (§5.2), delays 0, 1, 5, 50 samples and a fractional one."""
    cases = []
    for model, kw in (("rigid", {"mass": 5.4, "damping": 3.5}), ("cable", {"preset": "lhifam"})):
        for filt in (None, (30.0, 2)):
            for d in (0, 1, 5, 50, 2.37):
                name = f"FF LHifAM {model}{' 30 Hz' if filt else ''} d={d:g}"
                cases.append((name, {**kw, "delay": d * 1e-3, "human": _FF_HUMAN, "force_sensor": _FF_SENSOR}, filt))
    return cases


QUICK_FF = ("FF LHifAM rigid d=0", "FF LHifAM cable 30 Hz d=2.37")

QUICK = ("LHifAM rigid d=0", "rigid δ=1e-09 d=200", "LHifAM rigid d=5 B=0.4·B_max", "LHifAM cable d=3",
         "LHifAM rigid d=2.25")


@dataclass
class Measure:
    times: list[float] = field(default_factory=list)
    errors: list[float] = field(default_factory=list)
    estimates: list[float] = field(default_factory=list)
    cases: list[str] = field(default_factory=list)
    verify_times: list[float] = field(default_factory=list)
    """the cost of ``verify`` on each answer [ms] (optim.verification; its own column)"""
    verdicts: list[str] = field(default_factory=list)


def _control_loop(dev: Device, damping: float):
    """The loop as a lab would build it in python-control: c2d(G, 'zoh') · z^-d, damper closed by feedback.

    python-control has no fractional delay: those cases are None (not applicable).
    """
    import control

    from bench.bench_core import _control_system

    if not float(dev.delay_samples).is_integer() and abs(dev.delay_samples - round(dev.delay_samples)) > 1e-9:
        return None
    sys = _control_system(dev)
    if damping > 0:
        damper = control.tf([damping / dev.sample_time, -damping / dev.sample_time], [1.0, 0.0], dev.sample_time)
        sys = control.feedback(sys, damper)
    return sys


def _control_kcr(sys) -> tuple[float, float]:
    import control

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm = float(control.stability_margins(sys)[0])
        all_gm = np.atleast_1d(control.stability_margins(sys, returnall=True)[0])
    all_gm = all_gm[np.isfinite(all_gm) & (all_gm > 0)]
    return gm, (float(all_gm.min()) if all_gm.size else math.inf)


def _timed(fn, repeats: int):
    best, times = None, []
    for _ in range(repeats):
        t0 = time.perf_counter()
        best = fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return best, times


def _rel(x: float | None, truth: float) -> float:
    if x is None or not math.isfinite(x):
        return math.inf
    if truth == 0:
        return 0.0 if x == 0 else math.inf
    return abs(x / truth - 1)


def measure(names: tuple[str, ...] | None = None, repeats: int = 7) -> tuple[dict[str, Measure], list[dict]]:
    from optim.relay.experiment import relay_rung

    results = {k: Measure() for k in (*RUNGS, EXPERIMENT, *PEERS)}
    details = []
    for name, kw, frac in suite():
        if names is not None and name not in names:
            continue
        dev = Device(**kw)
        b = 0.0
        if frac:
            b = frac * analyse_stability(dev, damping=1e-9 * dev.damping_scale).max_stable_damping
        ref, ref_t = _timed(lambda: analyse_stability(dev, damping=b, method="reference"), 1)
        truth = ref.critical_stiffness
        row = {"case": name, "truth": truth}
        for rung in RUNGS:
            if rung == "reference":
                res, times = ref, ref_t
            else:
                res, times = _timed(lambda r=rung: analyse_stability(dev, damping=b, method=r), repeats)
            m = results[rung]
            m.times += times
            v, vt = _timed(lambda r=res: verify_analysis(dev, r), 1)
            m.verify_times += vt
            m.verdicts.append(v.verdict)
            m.errors.append(_rel(res.critical_stiffness, truth))
            m.estimates.append(res.error_estimate)
            m.cases.append(name)
            row[rung] = res.critical_stiffness
        if name in EXPERIMENT_CASES:
            rung = relay_rung(dev)
            m = results[EXPERIMENT]
            per_start = rung.elapsed * 1e3 / len(rung.ultimate_gains)
            for k in rung.ultimate_gains:
                m.times.append(per_start)
                m.errors.append(_rel(k, truth))
                m.cases.append(name)
            row[EXPERIMENT] = rung.spread
        sys = _control_loop(dev, b)
        if sys is None:
            for peer in PEERS:
                row[peer] = None
            details.append(row)
            continue
        (k_def, k_min), times = _timed(lambda: _control_kcr(sys), max(2, repeats // 3))
        for peer, k in zip(PEERS, (k_def, k_min)):
            m = results[peer]
            m.times += times
            m.errors.append(_rel(k, truth))
            m.cases.append(name)
            row[peer] = k
        details.append(row)
    return results, details


def measure_feedforward(names: tuple[str, ...] | None = None,
                        repeats: int = 7) -> tuple[dict[str, Measure], list[dict]]:
    """The same rungs on the force-feedforward loop: K_f,cr against the 40-digit residue reference."""
    from models.filters import ButterworthLowPass
    from optim.transparency.feedforward_ladder import analyse_force_feedforward

    results = {k: Measure() for k in RUNGS}
    details = []
    for name, kw, filt in feedforward_suite():
        if names is not None and name not in names:
            continue
        dev = Device(**kw)
        f = ButterworthLowPass(filt[1], filt[0], dev.sample_time) if filt else None
        ref, ref_t = _timed(lambda: analyse_force_feedforward(dev, f, method="reference"), 1)
        truth = ref.critical_force_gain
        row = {"case": name, "truth": truth}
        for rung in RUNGS:
            if rung == "reference":
                res, times = ref, ref_t
            else:
                res, times = _timed(lambda r=rung: analyse_force_feedforward(dev, f, method=r), repeats)
            m = results[rung]
            m.times += times
            v, vt = _timed(lambda r=res: verify_force_feedforward(dev, r, filt[1] if filt else None,
                                                                  filt[0] if filt else None), 1)
            m.verify_times += vt
            m.verdicts.append(v.verdict)
            m.errors.append(_rel(res.critical_force_gain, truth))
            m.estimates.append(res.error_estimate)
            m.cases.append(name)
            row[rung] = res.critical_force_gain
        details.append(row)
    return results, details


def _summary_rows(results: dict[str, Measure], keys) -> list[str]:
    lines = []
    for key in keys:
        m = results.get(key)
        if m is None or not m.errors:
            continue
        wrong = [c for c, e in zip(m.cases, m.errors) if e > 0.01]
        errs = np.array(m.errors)
        lines.append(
            f"| {key} | {statistics.median(m.times):.3g} | {np.percentile(m.times, 95):.3g} | "
            f"{np.median(errs):.1e} | {np.max(errs):.1e} | {len(wrong)}/{len(m.errors)} | {wrong[0] if wrong else '—'} | "
            f"{_verify_cells(m)} |")
    return lines


def _verify_cells(m: Measure) -> str:
    """verify's median cost and its verdicts (confirmed / contradicted / not checkable), or — for a peer."""
    if not m.verify_times:
        return "— | —"
    n = len(m.verdicts)
    return (f"{statistics.median(m.verify_times):.3g} | {m.verdicts.count('confirmed')}/{m.verdicts.count('contradicted')}"
            f"/{m.verdicts.count('not_checkable')} of {n}")


HEADER = ("| method | median ms | p95 ms | median rel. error | max rel. error | wrong > 1 % | first wrong case | "
          "verify median ms | verify confirmed/contradicted/not checkable |")
RULE = "|---|---|---|---|---|---|---|---|---|"
README_START, README_END = "<!-- accuracy-headline:start -->", "<!-- accuracy-headline:end -->"


def headline(results: dict[str, Measure]) -> str:
    """The README's headline table (written between its markers by main, so it cannot go stale)."""
    names = {"linear": "linear (eq. 10)", "python-control default": "python-control `stability_margins`"}
    lines = ["| method | median ms | max rel. error | wrong > 1 % | verify median ms |", "|---|---|---|---|---|"]
    for key in (*RUNGS, PEERS[0]):
        m = results.get(key)
        if m is None or not m.errors:
            continue
        wrong = sum(1 for e in m.errors if e > 0.01)
        err = "— (truth)" if key == "reference" else f"{max(m.errors):.1e}"
        ver = f"{statistics.median(m.verify_times):.3g}" if m.verify_times else "—"
        lines.append(f"| {names.get(key, key)} | {statistics.median(m.times):.2g} | {err} | {wrong}/{len(m.errors)} | "
                     f"{ver} |")
    return "\n".join(lines)


def write_readme_headline(readme: Path, table: str) -> None:
    text = readme.read_text()
    if README_START not in text or README_END not in text:
        raise SystemExit(f"{readme}: the markers {README_START} … {README_END} are missing")
    head, rest = text.split(README_START, 1)
    _, tail = rest.split(README_END, 1)
    readme.write_text(f"{head}{README_START}\n{table}\n{README_END}{tail}")


def render_feedforward(results: dict[str, Measure], details: list[dict]) -> str:
    lin = results["linear"]
    ratio = max(e / est for e, est in zip(lin.errors, lin.estimates) if math.isfinite(e) and est > 0)
    grid = results["grid"]
    g_ratio = max((e / est for e, est in zip(grid.errors, grid.estimates) if math.isfinite(e) and est > 0),
                  default=0.0)
    span = statistics.median(results["reference"].times) / statistics.median(results["linear"].times)
    lines = [
        "## Force feedforward: K_f,cr (chapter §5)", "",
        f"{len(details)} cases: LHifAM rigid and cable held by the eq. 30 grasp with the eq. 31 sensor, without a "
        "filter and with the chapter's 2nd-order 30 Hz Butterworth, delays 0, 1, 5, 50 and 2.37 samples. Truth: the "
        "`reference` rung (40-digit mpmath residue z-transform, optim/transparency/feedforward_reference.py). `linear` is eq. 33, "
        "K_f,cr ≈ 1 + m/m_h (a large-delay limit; its time includes its error estimate).", "",
        HEADER, RULE,
        *_summary_rows(results, RUNGS), "",
        f"The linear rung's reported error estimate: true error / estimate ≤ {ratio:.2f} on this suite (an honest "
        f"estimate stays ≤ 2); the grid rung's: ≤ {g_ratio:.2f}. Median time reference / linear: {span:.3g}×.", "",
        "| case | reference | exact | grid | linear (eq. 33) | linear estimate |", "|---|---|---|---|---|---|"]
    for r, est in zip(details, lin.estimates):
        lines.append(f"| {r['case']} | {r['truth']:.12g} | {r['exact']:.12g} | {r['grid']:.6g} | {r['linear']:.4g} | "
                     f"{est:.2g} |")
    lines.append("")
    return "\n".join(lines)


def render(results: dict[str, Measure], details: list[dict]) -> str:
    lines = [
        "# What accuracy costs in time",
        "",
        "## Critical stiffness K_cr (chapter §3-4)",
        "",
        f"Generated by `python -m bench.accuracy_vs_time` on {_dt.date.today().isoformat()}, "
        f"{platform.machine()}, CPython {platform.python_version()}, 2 cores. Truth: the `reference` rung "
        f"(40-digit mpmath, an independent implementation). {len(details)} cases: rigid and cable, delays 0–200 "
        "samples and fractional ones, δ from 1e-3 to 1e-12, virtual damping into the curved part of the boundary.",
        "",
        "python-control is given the loop as a lab would build it (`c2d(G, 'zoh')·z^-d`, the damper closed with "
        "`feedback`); it has no fractional delay, so those cases count only for zwidth's rungs.",
        "",
        HEADER, RULE,
    ]
    lines += _summary_rows(results, (*RUNGS, EXPERIMENT, *PEERS))
    lines += ["", "`verify` (docs/verification.md) checks each answer on the closed loop at its own claim: ±1e-6 for "
              "exact and reference, ± the error estimate for grid, ± twice the estimate for linear (its documented "
              "honesty); an unbounded estimate is not checkable.  A contradiction there is the rung's estimate "
              "failing, shown rather than hidden."]
    lin = results["linear"]
    ratio = [e / est for e, est in zip(lin.errors, lin.estimates) if math.isfinite(e) and est > 0]
    spreads = [f"{r['case']}: {r[EXPERIMENT][0]:.5g}–{r[EXPERIMENT][1]:.5g} (exact {r['exact']:.5g})"
               for r in details if EXPERIMENT in r]
    if spreads:
        lines += ["", "The relay experiment reads a different K_u from each start (FIELD-NOTES): "
                  + "; ".join(spreads) + " N/m. Each start counts as one answer above."]
    grid = results["grid"]
    g_fin = [e / est for e, est in zip(grid.errors, grid.estimates) if math.isfinite(e) and 0 < est < math.inf]
    g_inf = sum(1 for est in grid.estimates if est == math.inf)
    g_wrong_inf = sum(1 for e, est in zip(grid.errors, grid.estimates) if e > 0.01 and est == math.inf)
    g_wrong = sum(1 for e in grid.errors if e > 0.01)
    lines += ["", f"The linear rung's reported error estimate: true error / estimate ≤ {max(ratio):.2f} on the suite "
              "(an honest estimate stays ≤ 2).",
              "", f"The grid rung's reported error estimate: true error / estimate ≤ {max(g_fin, default=0.0):.2f} where it is "
              f"finite; {g_inf} answers are flagged unbounded (∞, null over HTTP: the grid's own samples show missed "
              f"crossovers), which covers {g_wrong_inf} of its {g_wrong} answers wrong by more than 1 %.", "",
              "## Per case (K_cr in N/m)", "",
              "| case | reference | exact | grid | linear | python-control default | python-control min |",
              "|---|---|---|---|---|---|---|"]
    for r in details:
        def fmt(x):
            return "n/a (fractional delay)" if x is None else f"{x:.6g}"
        lines.append(f"| {r['case']} | {r['truth']:.9g} | {r['exact']:.9g} | {r['grid']:.6g} | {r['linear']:.6g} | "
                     f"{fmt(r['python-control default'])} | {fmt(r['python-control min(returnall)'])} |")
    lines.append("")
    return "\n".join(lines)


def plot(results: dict[str, Measure], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    markers = {"linear": "o", "grid": "s", "exact": "D", "reference": "*", EXPERIMENT: "^",
               "python-control default": "x", "python-control min(returnall)": "+"}
    for key, m in results.items():
        if not m.errors:
            continue
        errs = np.clip(np.array(m.errors, dtype=float), 1e-17, 1e12)
        ax.scatter([statistics.median(m.times)], [np.median(errs)], marker=markers[key], s=70, label=f"{key} (median)")
        ax.scatter([statistics.median(m.times)], [np.max(errs)], marker=markers[key], s=25, alpha=0.5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time per answer [ms] (median)")
    ax.set_ylabel("relative error of K_cr (large: median, small: max)")
    ax.axhline(0.01, color="grey", lw=0.8, ls="--")
    ax.legend(fontsize=7)
    ax.set_title("zwidth accuracy ladder vs python-control")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="the 5-case version")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", default="docs/accuracy.md")
    ap.add_argument("--readme", default="README.md", help="README whose headline table is rewritten ('' to skip)")
    args = ap.parse_args(argv)
    results, details = measure(QUICK if args.quick else None, args.repeats)
    ff_results, ff_details = measure_feedforward(QUICK_FF if args.quick else None, args.repeats)
    text = render(results, details) + "\n" + render_feedforward(ff_results, ff_details)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    plot(results, out.with_suffix(".png"))
    if args.readme and not args.quick:
        write_readme_headline(Path(args.readme), headline(results))
    print(text)
    return text


if __name__ == "__main__":
    main()
