"""The crossover list near Nyquist (issue 34: an audit found one real crossover at θ = 3.13991 rad/sample, K = 2.47e10,
missing from a list): an aimed search for crossovers within 3e-2 (or 8/(d + 1)) rad/sample of π, each looked up in
the exact rung's list.

The reference is independent of zwidth's plant: tests/optim/independent.py's ZOH in physical coordinates (its own
matrix exponentials), G(e^{jθ}) = c·(zI − Φ)⁻¹·(Γ0 + Γ1 z⁻¹)·z^{−d} by numpy solves, H = −1/G_n + β(e^{−jθ} − 1) on
40,000 angles geometric in π − θ from 1e-9 to the width; a crossing is a sign change of Im H with Re H > 0 at both
ends away from a pole of H (|Im H| < 0.3 |H| at both ends).  Devices: one in three rigid, the rest cables with the
mode anywhere up to 0.99 of Nyquist; δ log-uniform 1e-12 to 0.1, delays log-uniform 1 to 2,000 samples by default
(``--log-delay``; whole for odd cases), β log-uniform 1e-12 to 0.3·min(1, 2/(d + 1)).  Only K_cr > 0 answers carry a list.

Writes the section "Crossovers near Nyquist" of docs/properties_analysis.md (the other sections are kept).  Usage:
    PYTHONPATH=. python -m bench.bench_nyquist_crossovers [--cases 2200] [--seed 34]
"""

from __future__ import annotations

import math
import platform
import time

import numpy as np

from bench.sections import load_text, parser, replace_section

MARKER = "## Crossovers near Nyquist (issue 34)"


def _independent_h(dev, beta: float, theta: np.ndarray) -> np.ndarray:
    from tests.optim.independent import discretise, physical_model

    a, b, c = physical_model(dev)
    phi, g0, g1, d = discretise(a, b, dev.delay_samples)
    z = np.exp(1j * theta)
    n = phi.shape[0]
    x = np.linalg.solve(z[:, None, None] * np.eye(n) - phi[None], (g0[None, :] + g1[None, :] / z[:, None])[:, :, None])
    g = (x[:, :, 0] @ c) * z ** (-d)
    return -1.0 / g + beta * (1.0 / z - 1.0)


def run(seed: int, n: int, log_delay: tuple[float, float] = (0.0, 3.3)) -> dict:
    from models.device import Device
    from optim.stability.analysis import analyse_stability

    rng = np.random.default_rng(seed)
    stats = {"devices": 0, "with_near": 0, "kcr0": 0, "crossings": 0, "within_1e-3": 0, "missing": 0, "refused": 0}
    missing: list[dict] = []
    closest = math.inf
    for i in range(n):
        t = float(rng.choice([5e-4, 1e-3, 2e-3]))
        m = 10 ** rng.uniform(-3, 1)
        delta = 10 ** rng.uniform(-12, -1)
        d = 10 ** rng.uniform(*log_delay)
        ds = float(round(d)) if i % 2 else d
        b = delta * m / t
        if i % 3 == 0:
            kw: dict = dict(mass=m, damping=b)
        else:
            mr = m * rng.uniform(0.05, 0.9)
            md = m - mr
            wn = math.pi / t * rng.uniform(0.05, 0.99)
            kc = wn ** 2 * mr * md / m
            br = b * rng.uniform(0, 1)
            bc = 2.0 * math.sqrt(kc * mr * md / m) * 10 ** rng.uniform(-9, 0)
            kw = dict(cable=dict(motor_mass=mr, body_mass=md, motor_damping=br, body_damping=b - br, stiffness=kc,
                                 damping=bc))
        dev = Device(sample_time=t, delay=ds * t, **kw)
        beta = 10 ** rng.uniform(-12, -0.5) * min(1.0, 2.0 / (ds + 1))
        stats["devices"] += 1
        w = min(3e-2, 8.0 / (ds + 1))
        th = math.pi - np.geomspace(1e-9, w, 40000)[::-1]
        h = _independent_h(dev, beta, th)
        im, re = h.imag, h.real
        ok = (np.sign(im[:-1]) * np.sign(im[1:]) < 0) & (re[:-1] > 0) & (re[1:] > 0) & \
             (np.abs(im[:-1]) < 0.3 * np.abs(h[:-1])) & (np.abs(im[1:]) < 0.3 * np.abs(h[1:]))
        idx = np.nonzero(ok)[0]
        if idx.size == 0:
            continue
        stats["with_near"] += 1
        try:
            a = analyse_stability(dev, None, beta * m / t)
        except ValueError:
            stats["refused"] += 1
            continue
        if not a.critical_stiffness:
            stats["kcr0"] += 1
            continue
        listed = [c.frequency * t for c in a.crossovers]
        for j in idx:
            thc = 0.5 * (th[j] + th[j + 1])
            closest = min(closest, math.pi - thc)
            stats["crossings"] += 1
            stats["within_1e-3"] += math.pi - thc < 1e-3
            if not any(abs(f - thc) <= max(2 * (th[j + 1] - th[j]), 1e-12) for f in listed):
                stats["missing"] += 1
                missing.append({"i": i, "theta": float(thc), "K": float(re[j] * dev.stiffness_scale),
                                "device": dev.model_dump(exclude_none=True), "B": beta * m / t})
    return {**stats, "closest": closest, "missing_cases": missing}


def main() -> None:
    ap = parser(2200, 34, workers=False)
    ap.add_argument("--log-delay", type=float, nargs=2, default=(0.0, 3.3),
                    help="delays log-uniform between 10^LO and 10^HI samples (long delays put crossings nearer π)")
    args = ap.parse_args()
    load = load_text()
    t0 = time.perf_counter()
    r = run(args.seed, args.cases, tuple(args.log_delay))
    wall = time.perf_counter() - t0
    lines = [
        MARKER, "",
        f"Generated by `bench/bench_nyquist_crossovers.py --cases {args.cases} --seed {args.seed} --log-delay "
        f"{args.log_delay[0]:g} {args.log_delay[1]:g}` on "
        f"{platform.machine()} in {wall:.0f} s (load before: {load}); the method is in the script's docstring.",
        "",
        "| quantity | value |", "|---|---|",
        f"| devices drawn | {r['devices']} |",
        f"| with a crossing within the window by the independent scan | {r['with_near']} |",
        f"| of which K_cr = 0 (no list) / refused | {r['kcr0']} / {r['refused']} |",
        f"| crossings looked up in the exact rung's list | {r['crossings']} |",
        f"| of which within 1e-3 rad/sample of π | {r['within_1e-3']} |",
        f"| closest to π | {r['closest']:.3g} rad/sample |",
        f"| missing from the list | {r['missing']} |",
        "",
    ]
    if r["missing_cases"]:
        lines += ["Missing (first 10):", ""] + [f"- `{c}`" for c in r["missing_cases"][:10]] + [""]
    replace_section(args.out, MARKER, lines)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
