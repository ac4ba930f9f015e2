"""CPU time of the cable study's chunks in this process (issue 32): what a local worker spends per point.

    PYTHONPATH=. python -m bench.profile_cable_chunk                      # CPU per group / point, a few chunks
    PYTHONPATH=. python -m bench.profile_cable_chunk --profile 30         # also cProfile's top 30 of one chunk
    PYTHONPATH=. python -m bench.profile_cable_chunk --against DIR        # the same, alternated with the source in DIR
    PYTHONPATH=. python -m bench.profile_cable_chunk --against DIR --consecutive --chunks 40 --chunk 6250 --rounds 1
        # 40 consecutive chunks in one process, as a pool worker takes ~250k points (what it keeps grows: caches, gc)

The chunks are bench.bench_studies' cable grid (lhifam preset, cable stiffness × 21 whole delays × 50 cable dampings,
1M points): each (cable stiffness, cable damping) pair is a "group" of 21 points (its delays), one modal factoring.
A chunk is evaluated as a worker evaluates it (service.studies.blocks.evaluate_planned: the column path, the
block's encoding), after a warm-up chunk and gc.freeze() (as service._warm leaves a worker).  CPU time
(time.process_time), not wall time: the machine is shared.  ``--against DIR`` runs a second process on another
version's source (e.g. ``git archive <commit> | tar -x -C DIR``) and alternates the two, chunk set by chunk set, so
the ratio is of one run under one load.  Each chunk's CPU time spent in the garbage collector is reported beside it
(gc.callbacks), and ``--consecutive`` takes the chunks one after the other (a worker's long run) instead of apart.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import subprocess
import sys
import time

POINTS = 1_000_000
GROUP = 21          # whole delays per (cable stiffness, cable damping) pair


def _plan(problem: str):
    from bench.bench_studies import cable_study
    from optim.studies.problems import plan_study

    req = cable_study(problem, POINTS)
    return plan_study(req["problem"], req["base"]["device"], req["base"]["requirements"], req["sweep"])


def measure(problem: str, chunk: int, starts: list[int], profile: int = 0) -> dict:
    """CPU seconds of evaluate_planned on each chunk (start, chunk points) of the cable grid, in this process."""
    from service.studies.blocks import evaluate_planned

    plan = _plan(problem)
    evaluate_planned(plan, POINTS - 2 * GROUP * 50, GROUP * 50)     # warm: compiled kernels, caches
    gc.freeze()
    in_gc = [0.0, 0.0]

    def timer(phase: str, info: dict) -> None:
        if phase == "start":
            in_gc[1] = time.process_time()
        else:
            in_gc[0] += time.process_time() - in_gc[1]

    gc.callbacks.append(timer)
    cpu, gc_cpu = [], []
    for s in starts:
        g0 = in_gc[0]
        t0 = time.process_time()
        evaluate_planned(plan, s, chunk)
        cpu.append(time.process_time() - t0)
        gc_cpu.append(in_gc[0] - g0)
    gc.callbacks.remove(timer)
    out = {"cpu": cpu, "gc": gc_cpu, "chunk": chunk}
    if profile:
        import cProfile
        import io
        import pstats

        pr = cProfile.Profile()
        pr.enable()
        evaluate_planned(plan, starts[-1] + chunk, chunk)       # points not seen before (no cached plant)
        pr.disable()
        buf = io.StringIO()
        pstats.Stats(pr, stream=buf).sort_stats("tottime").print_stats(profile)
        out["profile"] = buf.getvalue()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problem", default="critical_stiffness")
    ap.add_argument("--chunk", type=int, default=GROUP * 50 * 10, help="points per chunk (default 10,500: 500 groups)")
    ap.add_argument("--chunks", type=int, default=3, help="chunks per round")
    ap.add_argument("--rounds", type=int, default=3, help="rounds (with --against: each version once per round)")
    ap.add_argument("--profile", type=int, default=0, help="print cProfile's top N functions of one chunk")
    ap.add_argument("--against", default=None, help="another version's source directory, alternated with this one")
    ap.add_argument("--consecutive", action="store_true",
                    help="a round's chunks one after the other in the grid (a worker's run), not spread over it")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--first", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    step = POINTS // (args.chunks * args.rounds + 1) // (GROUP * 50) * (GROUP * 50)
    if args.child:
        starts = [args.first + k * (args.chunk if args.consecutive else step) for k in range(args.chunks)]
        print(json.dumps(measure(args.problem, args.chunk, starts, args.profile)))
        return
    here = os.getcwd()
    versions = [("this", here)] + ([("against", os.path.abspath(args.against))] if args.against else [])
    per_group: dict[str, list[float]] = {name: [] for name, _ in versions}
    gc_point: dict[str, list[float]] = {name: [] for name, _ in versions}
    for r in range(args.rounds):
        for name, src in versions:
            env = dict(os.environ, PYTHONPATH=src)
            # this file run on the other source (its modules first on the path): the same measurement of both
            cmd = [sys.executable, os.path.abspath(__file__), "--child", "--problem", args.problem,
                   "--chunk", str(args.chunk), "--chunks", str(args.chunks), "--rounds", str(args.rounds),
                   "--first", str(r * args.chunks * step), "--profile", str(args.profile if r == 0 else 0)]
            cmd += ["--consecutive"] if args.consecutive else []
            got = json.loads(subprocess.run(cmd, cwd=src, env=env, capture_output=True, text=True,
                                            check=True).stdout.strip().splitlines()[-1])
            groups = args.chunk / GROUP
            per_group[name] += [c / groups for c in got["cpu"]]
            gc_point[name] += [c / args.chunk for c in got["gc"]]
            if got.get("profile"):
                print(f"--- cProfile of one {args.chunk}-point chunk, {name} ({src})\n{got['profile']}")
            print(f"round {r} {name}: " + " ".join(f"{1e3 * c / groups:.3f}" for c in got["cpu"]) + " ms/group; gc "
                  + " ".join(f"{1e6 * c / args.chunk:.1f}" for c in got["gc"]) + " µs/point", flush=True)
    load = os.getloadavg()[0]
    print(f"\n{args.problem}, chunks of {args.chunk} points ({args.chunk // GROUP} groups of {GROUP}); "
          f"load (1 min) at the end {load:.1f}")
    med = {}
    for name, xs in per_group.items():
        xs = sorted(xs)
        med[name] = xs[len(xs) // 2]
        print(f"{name:8s}: median {1e3 * med[name]:.3f} ms/group = {1e6 * med[name] / GROUP:.1f} µs/point = "
              f"{GROUP / med[name]:,.0f} points per CPU-s (min {1e3 * xs[0]:.3f}, max {1e3 * xs[-1]:.3f}; {len(xs)} chunks)"
              f"; in gc: median {1e6 * sorted(gc_point[name])[len(xs) // 2]:.1f} µs/point")
    if "against" in med:
        print(f"ratio this/against (CPU per point, medians): {med['this'] / med['against']:.3f}")


if __name__ == "__main__":
    main()
