"""The V(π) = 0 property run: random rendered walls whose velocity estimate vanishes at the Nyquist point (moving
averages of an even length, order-2 Butterworth low-passes), rigid and cable, M of either sign; every B_max side and
every end of the stable virtual-mass range (rendered_mass_range) checked against closed-loop eigenvalues.

Where V(−1) = 0, θ = π is a pole of h_B and h_M (not a crossing): before the fix both the scan and the certified path
listed a rounding value there, which could cut the virtual-mass walk and B_max short.

The checks (optim/stability/closed_loop_rendered.py's matrix with the filter's and the mass's states, written from
the filter's specification, no code shared with the crossings):

* B_max finite > 0: the K = 0⁺ loop (the K = 0 closed loop without its pole at z = 1) stable at B_max·(1 − s) and
  unstable at B_max·(1 + s), s the first of 1e-6, 1e-4, 1e-2 at which both sides are decided; B_max = 0: unstable
  at β = 1e-6; inf: stable at B = (1, 10², 10⁴)·m/T.  Each eigenvalue with its rounding bound (Wilkinson, as
  optim.stability.closed_loop.radius_excess); undetermined where a bound straddles the circle at every step.  nan
  (the analysis's own "not resolved") is counted as undecided, not checked.
* mass range at (K, B), K = u·K_cr(B), B = u'·B_max: each finite end e is stable at e − s·(e − M) and unstable at
  e + s·(e − M), s as above (optim.verification.check_point: eigenvalues, else the argument principle); an infinite
  end stable at M ± (10, 10³)·m.

``--baseline COMMIT`` runs the same walls (same seed) on COMMIT's tree first (exported with git archive to a
temporary directory, this file run against it) and then on this tree, in one invocation: the before/after table.
B and K are drawn as fractions of the version's own B_max and K_cr, so walls differ only where those answers do.

A second family (``--averages N``, seed + 1): moving averages of 3–40 samples, odd and even alike, whose zeros
e^{2πjk/n} on the circle are poles of h_B and h_M at every 2πk/n < π (the scan, with V by Horner, listed a pole's own
sample as a crossing: a 16-sample average at 6π/16 with h_B ≈ −2e16); the same checks, plus the count of listed
B and M crossings within 1e-9 of a pole (each run's own listing: none is a crossing).

Writes docs/properties_filter_pi.md (generated; never edit by hand).  Usage:
    PYTHONPATH=. python -m bench.bench_pi_zero_properties [--cases 3000] [--averages 1500] [--seed 31]
        [--baseline COMMIT]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "properties_filter_pi.md"
#: the relative steps off an answer tried in turn: the first at which the closed loop decides both sides labels it
#: (a pole 1e-6 off B_max is often within the eigenvalues' rounding bound of the circle)
_STEPS = (1e-6, 1e-4, 1e-2)


def _reduced_verdict(q: np.ndarray) -> str:
    """'stable' / 'unstable' / 'undetermined' of the K = 0 closed loop with its pole at z = 1 removed (Q = M − I:
    the eigenvalue of Q nearest 0), each eigenvalue with its rounding bound (radius_excess's)."""
    from scipy.linalg import eig, matrix_balance

    from optim.stability.closed_loop import _SAFETY
    qb, _ = matrix_balance(q, permute=False)
    w, vl, vr = eig(qb, left=True, right=True)
    vl = vl / np.linalg.norm(vl, axis=0)
    vr = vr / np.linalg.norm(vr, axis=0)
    cond = 1.0 / np.maximum(np.abs(np.sum(vl.conj() * vr, axis=0)), 1e-300)
    err = _SAFETY * np.finfo(float).eps * np.linalg.norm(qb, 2) * cond
    one = int(np.argmin(np.abs(w)))
    if not abs(w[one]) < 1e-7:
        return "undetermined"
    keep = np.arange(w.size) != one
    w, err = w[keep], err[keep]
    ex = (2.0 * w.real + (w.real ** 2 + w.imag ** 2)) / (np.abs(1.0 + w) + 1.0)
    if np.any(ex - err > 0.0):
        return "unstable"
    if np.all(ex + err < 0.0):
        return "stable"
    return "undetermined"


def _label(claims: list[tuple[str, str]]) -> str:
    """confirmed when every (claimed, found) agrees, contradicted when one is opposite, else undetermined."""
    if any(found != "undetermined" and found != want for want, found in claims):
        return "contradicted"
    return "confirmed" if all(found == want for want, found in claims) else "undetermined"


def _stepped(claims_at) -> str:
    """``claims_at(step)``'s label at the first step of _STEPS that is not undetermined ("confirmed 1e-06", …)."""
    for step in _STEPS:
        label = _label(claims_at(step))
        if label != "undetermined":
            return f"{label} {step:g}"
    return "undetermined"


def _walls(cases: int, seed: int, family: str = "pi"):
    from models.velocity_filter import LowPass, MovingAverage
    from tests.optim.stability.filter_properties import random_device
    rng = np.random.default_rng(seed)
    for i in range(cases):
        dev = random_device(rng)
        kind = ("moving_average_even", "low_pass_2")[i % 2] if family == "pi" else "moving_average_3_40"
        if kind == "moving_average_3_40":
            spec = MovingAverage(kind="moving_average", samples=int(rng.integers(3, 41)))
        elif kind == "moving_average_even":
            spec = MovingAverage(kind="moving_average", samples=2 * int(rng.integers(1, 11)))
        else:
            spec = LowPass(kind="low_pass", cutoff_hz=float(10 ** rng.uniform(-3, math.log10(0.45)) / dev.sample_time),
                           order=2)
        mass = dev.mass * float(rng.uniform(-0.9, 1.0))
        yield i, kind, dev, spec, mass, float(rng.uniform(0.0, 1.0)), float(rng.uniform(0.05, 0.95))


def _at_poles(dev, r, beta: float, mu: float, rel: float) -> int:
    """B and M crossings the analysis lists within ``rel``·θ_p of a pole θ_p = 2πk/n < π of h_B, h_M (every
    listing of the walk: the K = 0⁺ loop's at M = 0, at this M and at this B).  Within 1e-12: a pole's own sample
    (the scan's fake); within 1e-9 a genuine crossing can sit (h ≈ c/(θ − θ_p) + d with c almost real: a 30-sample
    average's h_M at 2π/3·(1 + 9.95e-10), μ = −1.66e9, a sign change of Im h with V in mpmath,
    tests/optim/stability/test_circle_zeros.py)."""
    from optim.stability import rendered as R
    n = len(r.velocity.r)
    poles = [2.0 * math.pi * k / n for k in range(1, (n + 1) // 2)]
    found = [*R._damper_crossings(dev, r, 0.0), *R._damper_crossings(dev, r, mu), *R._mass_crossings(dev, r, 0.0),
             *R._mass_crossings(dev, r, beta)]
    return sum(1 for c in found if any(abs(c.angle - p) <= rel * p for p in poles))


def run(cases: int, seed: int, family: str = "pi") -> dict:
    """Every wall's B_max and mass-range labels (the worker: imports whatever tree PYTHONPATH gives)."""
    from models.errors import InputError
    from models.velocity_filter import rendering
    from optim.stability.closed_loop import sampled_plant
    from optim.stability.closed_loop_rendered import rendered_closed_loop
    from optim.stability.rendered import rendered_critical_stiffness, rendered_mass_range, rendered_max_stable_damping
    from optim.verification import check_point

    out: dict = {"walls": 0, "b_max": Counter(), "mass": Counter(), "refused": Counter(), "contradicted": [],
                 "undetermined": [], "cable": 0, "negative_mass": 0, "ms": [], "at_poles_own": 0,
                 "at_pole_walls_own": 0, "at_poles_near": 0, "at_pole_walls_near": 0}
    for i, kind, dev, spec, mass, ub, uk in _walls(cases, seed, family):
        t, m = dev.sample_time, dev.mass
        case = f"{kind} {spec!r} M={mass!r} device={dev.model_dump(exclude_none=True)!r}"
        t0 = time.perf_counter()
        try:
            r = rendering(spec, mass, t)
            b_max = rendered_max_stable_damping(dev, r)
        except InputError as exc:
            out["refused"][f"{exc.field}: {exc.rule}"] += 1
            continue
        out["walls"] += 1
        out["cable"] += dev.cable is not None
        out["negative_mass"] += mass < 0
        plant = sampled_plant(dev)
        mu = mass / m

        def reduced(b: float) -> str:
            return _reduced_verdict(rendered_closed_loop(plant, spec, t, 0.0, b / dev.damping_scale, mu))

        if math.isnan(b_max):
            label = "undecided"
        elif b_max == 0.0:
            label = _label([("unstable", reduced(1e-6 * dev.damping_scale))])
        elif math.isinf(b_max):
            label = _label([("stable", reduced(s * dev.damping_scale)) for s in (1.0, 1e2, 1e4)])
        else:
            label = _stepped(lambda s: [("stable", reduced(b_max * (1 - s))), ("unstable", reduced(b_max * (1 + s)))])
        out["b_max"][label] += 1
        if label.startswith("contradicted") or label == "undetermined":
            out[label.split()[0]].append(f"B_max={b_max!r} ({label}): {case}")
        top = b_max if math.isfinite(b_max) and b_max > 0 else 10 * max(dev.damping, 1e-3)
        damping = ub * top
        if family != "pi":
            for rel, key in ((1e-12, "own"), (1e-9, "near")):
                try:
                    bad = _at_poles(dev, r, damping / dev.damping_scale, mu, rel)
                except InputError:
                    bad = 0
                out[f"at_poles_{key}"] += bad
                out[f"at_pole_walls_{key}"] += bad > 0
        try:
            kc = rendered_critical_stiffness(dev, damping, r).critical_stiffness
            if kc is None or kc == 0.0:
                out["mass"]["no stable K"] += 1
                out["ms"].append((time.perf_counter() - t0) * 1e3)
                continue
            k = uk * (kc if math.isfinite(kc) else dev.stiffness_scale)
            mr = rendered_mass_range(dev, k, damping, r)
        except InputError as exc:
            out["refused"][f"{exc.field}: {exc.rule}"] += 1
            continue
        out["ms"].append((time.perf_counter() - t0) * 1e3)
        if mr is None:
            out["mass"]["no range"] += 1
            continue
        alpha, beta = k / dev.stiffness_scale, damping / dev.damping_scale

        def point(mm: float) -> str:
            p = check_point(dev, plant, alpha, beta, (spec, mm))
            return "undetermined" if p.stable is None else "stable" if p.stable else "unstable"

        for end, sign in ((mr.min, -1.0), (mr.max, 1.0)):
            if math.isinf(end):
                claims = [("stable", point(mass + sign * s * m)) for s in (10.0, 1e3)]
            else:
                gap = end - mass
                claims = lambda s, e=end, g=gap: [("stable", point(e - s * g)), ("unstable", point(e + s * g))]  # noqa: E731
            label = _label(claims) if isinstance(claims, list) else _stepped(claims)
            out["mass"][label] += 1
            if label.startswith("contradicted") or label == "undetermined":
                out[label.split()[0]].append(f"mass {'max' if sign > 0 else 'min'}={end!r} ({label}; K={k!r}, "
                                             f"B={damping!r}): {case}")
    return out


def _worker(tree: Path, cases: int, seed: int, family: str = "pi") -> dict:
    """This file's ``run`` in a subprocess importing ``tree`` (its own numba cache)."""
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as f:
        path = f.name
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(Path(tempfile.gettempdir()) / "pi_zero_numba"))
    t0 = time.perf_counter()
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker", path, "--cases", str(cases),
                    "--seed", str(seed), "--family", family], env=env, cwd=str(tree), check=True)
    data = json.loads(Path(path).read_text())
    data["wall_s"] = time.perf_counter() - t0
    os.unlink(path)
    return data


def _split(c: dict, word: str) -> str:
    """'total (at ∓1e-06 / 1e-04 / 0.01)' of the labels starting with ``word``; plain count without steps."""
    steps = [sum(n for k, n in c.items() if k == f"{word} {s:g}") for s in _STEPS]
    plain = c.get(word, 0)
    total = plain + sum(steps)
    return f"{total} ({plain} / " + " / ".join(map(str, steps)) + ")"


def _column(d: dict, family: str = "pi") -> list[str]:
    ms = np.array(d["ms"]) if d["ms"] else np.zeros(1)
    extra = [] if family == "pi" else [f"{d[f'at_poles_{k}']} ({d[f'at_pole_walls_{k}']} walls)" for k in ("own", "near")]
    return [str(d["walls"]), str(d["cable"]), str(d["negative_mass"]), *extra,
            _split(d["b_max"], "confirmed"), _split(d["b_max"], "contradicted"),
            *[str(d["b_max"].get(k, 0)) for k in ("undetermined", "undecided")],
            _split(d["mass"], "confirmed"), _split(d["mass"], "contradicted"), str(d["mass"].get("undetermined", 0)),
            str(sum(d["refused"].values())), f"{np.percentile(ms, 50):.1f} / {np.percentile(ms, 90):.1f}",
            f"{d['wall_s']:.0f}"]


_STEP_NOTE = "(B_max = 0 or inf, an infinite end / at ∓" + " / ∓".join(f"{s:g}" for s in _STEPS) + ")"
_ROWS = ["walls analysed", "cable devices", "negative virtual mass", f"B_max confirmed {_STEP_NOTE}",
         f"B_max contradicted {_STEP_NOTE}", "B_max undetermined (eigenvalue bounds straddle the circle at every step)",
         "B_max undecided by the analysis (nan: not checked)", f"mass-range ends confirmed {_STEP_NOTE}",
         f"mass-range ends contradicted {_STEP_NOTE}", "mass-range ends undetermined", "refused (422)",
         "analysis ms p50 / p90", "run wall time [s]"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--averages", type=int, default=1500, help="walls of the second family (averages of 3–40)")
    ap.add_argument("--family", default="pi", help=argparse.SUPPRESS)
    ap.add_argument("--baseline", help="a commit to run the same walls on first (the before column)")
    ap.add_argument("--out", type=Path, default=OUT, help="where the table goes (a reduced run: not the doc)")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            data = run(args.cases, args.seed, args.family)
        Path(args.worker).write_text(json.dumps(data))
        return
    families = [(f, n, args.seed + j) for j, (f, n) in enumerate((("pi", args.cases), ("averages", args.averages)))
                if n > 0]
    columns: dict[str, list[tuple[str, dict]]] = {f: [] for f, _, _ in families}
    load = os.getloadavg()
    if args.baseline:
        commit = subprocess.run(["git", "rev-parse", "--short", args.baseline], cwd=ROOT, check=True,
                                capture_output=True, text=True).stdout.strip()
        with tempfile.TemporaryDirectory() as tmp:
            archive = subprocess.run(["git", "archive", commit], cwd=ROOT, check=True, capture_output=True).stdout
            subprocess.run(["tar", "-x", "-C", tmp], input=archive, check=True)
            for f, n, seed in families:
                columns[f].append((f"before ({commit})", _worker(Path(tmp), n, seed, f)))
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True, capture_output=True,
                          text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, check=True,
                           capture_output=True, text=True).stdout.strip()
    for f, n, seed in families:
        columns[f].append((f"this tree (HEAD {head}{' + changes' if dirty else ''})", _worker(ROOT, n, seed, f)))
    load_end = os.getloadavg()
    lines = [
        "# Property runs: velocity filters with zeros on the unit circle (V(π) = 0; moving averages' 2πk/n)",
        "",
        f"Generated by `bench/bench_pi_zero_properties.py --cases {args.cases} --averages {args.averages} --seed "
        f"{args.seed}" + (f" --baseline {args.baseline}`" if args.baseline else "`")
        + f" on {platform.machine()}, load average {load[0]:.1f} at the start and {load_end[0]:.1f} at the end "
        "(a shared machine: times are upper bounds).  Devices from tests/optim/stability/filter_properties.py "
        "(rigid and cable, δ log-uniform in [1e-7, 1], delays 0–120 samples whole and fractional, T 0.1–10 ms); "
        "M uniform in [−0.9, 1]·m; B uniform in [0, B_max(M)] (10·max(b, 1e-3) where "
        "B_max is not finite and positive), K uniform in [0.05, 0.95]·K_cr(B).  The checks (module docstring): B_max "
        "by the K = 0⁺ loop's eigenvalues at B_max·(1 ∓ s), each end e of the virtual-mass range by the closed loop "
        "at e ∓ s·(e − M) (eigenvalues, else the argument principle), s the first of "
        + ", ".join(f"{s:g}" for s in _STEPS) + " at which both sides are decided (a pole 1e-6 off B_max is often "
        "within the eigenvalues' rounding bound of the circle).  Every column of a table runs the same walls (same "
        "seed); B and K are fractions of each version's own B_max and K_cr.",
        "",
    ]
    titles = {"pi": ("## V(π) = 0: even moving averages (2–20 samples) and order-2 Butterworth low-passes "
                     f"(f·T log-uniform in [1e-3, 0.45]), alternating; seed {args.seed}"),
              "averages": ("## Moving averages of 3–40 samples (odd and even): zeros at every 2πk/n; seed "
                           f"{args.seed + 1}")}
    for f, _, _ in families:
        rows = _ROWS if f == "pi" else _ROWS[:3] + ["B and M crossings listed within 1e-12·θ of a pole θ = 2πk/n < π (its own sample)",
                                    "… within 1e-9·θ (a genuine crossing can sit there: module docstring)"] + _ROWS[3:]
        lines += [titles[f], "", "| quantity | " + " | ".join(name for name, _ in columns[f]) + " |",
                  "|---|" + "---|" * len(columns[f])]
        cols = [_column(d, f) for _, d in columns[f]]
        lines += [f"| {row} | " + " | ".join(c[j] for c in cols) + " |" for j, row in enumerate(rows)]
        lines.append("")
        for name, d in columns[f]:
            if d["contradicted"]:
                lines += [f"Contradicted, {name} (first 15 of {len(d['contradicted'])}):", ""]
                lines += [f"- `{c}`" for c in d["contradicted"][:15]] + [""]
            if d["undetermined"]:
                lines += [f"Undetermined, {name} (first 5 of {len(d['undetermined'])}):", ""]
                lines += [f"- `{c}`" for c in d["undetermined"][:5]] + [""]
            if d["refused"]:
                lines += [f"Refused, {name}:", ""] + [f"- {c} ({n})" for c, n in Counter(d["refused"]).most_common()]
                lines.append("")
    args.out.write_text("\n".join(lines))
    print(args.out.read_text())


if __name__ == "__main__":
    main()
