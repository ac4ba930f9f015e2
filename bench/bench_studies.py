"""Study throughput: points per second of whole studies (planner, executor, store) against the
single-point baseline (the same evaluations one by one in this process, no store), side by side.

    PYTHONPATH=. python -m bench.bench_studies          # writes docs/bench_studies.md

Each configuration runs the same study ``repeats`` times on a fresh SQLite store; the pool (or
the Dask cluster) is started and warmed before timing, as a running service's would be.
"""

from __future__ import annotations

import argparse
import datetime
import platform
import statistics
import tempfile
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from optim.studies import ProblemUnavailable, evaluate_point, get_problem
from service.studies.executors import DaskExecutor, LocalExecutor
from service.studies.runner import StudyRunner, plan_from_request
from service.studies.store import StudyStore

ROOT = Path(__file__).resolve().parents[1]
#: Throughput goals of issue 8 on 2 cores [points/s].
GOALS = {"stability": 2000, "critical_stiffness": 2000, "stiffness": 200}
#: Points per chunk of the vectorised problem: one batch_critical_stiffness call per delay class of a chunk,
#: whose per-call numpy overhead is spread over the chunk (≈ 4000 points/CPU-s from 128 to 512 points).
CRITICAL_CHUNK = 256


def stability_study(points: int) -> dict:
    """Rigid LHifAM wall (K = 1500 N/m) over delay × virtual damping: every point a full exact analysis."""
    n_delay = max(1, points // 4)
    return {"problem": "stability", "base": {"device": {"mass": 5.4, "damping": 3.5}, "requirements": {"stiffness": 1500.0}},
            "sweep": {"device.delay": {"start": 0.0, "stop": 0.004, "num": n_delay},
                      "requirements.damping": [0.0, 2.0, 5.0, 10.0]}}


def critical_study(points: int) -> dict:
    """The stability study's wall and sweep, on the vectorised K_cr problem (a whole chunk per batch)."""
    return {**stability_study(points), "problem": "critical_stiffness"}


def stiffness_study(points: int) -> dict:
    """Stiffness design (optim.stiffness, when in this build) over delay × gain margin."""
    n_delay = max(1, points // 2)
    return {"problem": "stiffness", "base": {"device": {"mass": 5.4, "damping": 3.5}, "requirements": {}},
            "sweep": {"device.delay": {"start": 0.0, "stop": 0.004, "num": n_delay},
                      "requirements.min_gain_margin_db": [6.0, 10.0]}}


@dataclass(frozen=True)
class Row:
    problem: str
    executor: str
    points: int
    times: tuple[float, ...]
    """wall time of each repeat [s]."""
    failed: int
    cpu: float | None = None
    """CPU time of the processes that evaluated the points, median over the repeats [s]."""
    chunk: int | None = None
    """points per chunk (None: the in-process baseline, one point at a time)."""

    @property
    def median(self) -> float:
        return statistics.median(self.times)

    @property
    def p95(self) -> float:
        return float(np.percentile(self.times, 95))

    @property
    def rate(self) -> float:
        return self.points / self.median

    @property
    def cpu_rate(self) -> float | None:
        """Points per CPU-second of the evaluating processes: what a free core gives, whatever else runs."""
        return self.points / self.cpu if self.cpu else None


def _worker_cpu(executor) -> float | None:
    """Total CPU seconds used so far by the executor's worker processes."""
    import psutil

    if isinstance(executor, LocalExecutor):
        pool = executor._pool
        if pool is None:
            return None
        return sum(sum(psutil.Process(p).cpu_times()[:2]) for p in list(pool._processes))
    if isinstance(executor, DaskExecutor):
        return sum(executor.client.run(time.process_time).values())
    return None


def _baseline(study: dict, repeats: int) -> Row:
    plan = plan_from_request(study)
    inputs = [plan.inputs(v) for v in plan.values(0, plan.total).tolist()]
    evaluate_point(plan.problem, *inputs[0])  # imports and caches outside the timing
    times, cpus, failed = [], [], 0
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        failed = sum(evaluate_point(plan.problem, dev, req)[1] is not None for dev, req in inputs)
        times.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    return Row(plan.problem, "single point, in-process (baseline)", plan.total, tuple(times), failed,
               statistics.median(cpus))


def _study(study: dict, executor, label: str, repeats: int, chunk_size: int) -> Row:
    plan = plan_from_request(study)
    times, cpus, failed = [], [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(repeats + 1):  # the first run warms the workers (imports, solver caches)
            store = StudyStore(f"sqlite:///{tmp}/bench{r}.db")
            store.migrate()
            sid = str(uuid.uuid4())
            store.create(sid, plan.problem, study, plan.total)
            runner = StudyRunner(store, lambda: executor, chunk_size=chunk_size)
            c0 = _worker_cpu(executor)
            t0 = time.perf_counter()
            runner.run_until_idle()
            elapsed = time.perf_counter() - t0
            c1 = _worker_cpu(executor)
            row = store.get(sid)
            store.dispose()
            if row["status"] != "done":
                raise RuntimeError(f"{label}: study ended {row['status']}: {row['error']}")
            if r:
                times.append(elapsed)
                failed = row["failed"]
                if c0 is not None and c1 is not None:
                    cpus.append(c1 - c0)
    return Row(plan.problem, label, plan.total, tuple(times), failed, statistics.median(cpus) if cpus else None,
               chunk_size)


def measure(points: int = 400, repeats: int = 3, workers: tuple[int, ...] = (1, 2), dask: bool = True,
            chunk_size: int = 32, critical_points: int | None = None, critical_chunk: int = CRITICAL_CHUNK,
            stiffness_points: int | None = None) -> list[Row]:
    """``critical_points`` (default 10 × points) of the vectorised problem run in chunks of ``critical_chunk``,
    on the local pools only (its study is short: a Dask cluster's start would dominate the run)."""
    studies = [(stability_study(points), chunk_size, dask),
               (critical_study(critical_points or 10 * points), critical_chunk, False)]
    try:
        get_problem("stiffness")
        studies.append((stiffness_study(max(2, stiffness_points or points)), chunk_size, dask))
    except ProblemUnavailable:
        pass
    rows: list[Row] = []
    for study, chunk_size, dask in studies:
        rows.append(_baseline(study, repeats))
        for n in workers:
            ex = LocalExecutor(n)
            try:
                rows.append(_study(study, ex, f"local pool, {n} worker{'s' if n > 1 else ''}", repeats, chunk_size))
            finally:
                ex.close()
        if dask:
            from bench.dask_cluster import local_dask_cluster

            with local_dask_cluster(workers=2) as address:
                ex = DaskExecutor(address)
                try:
                    rows.append(_study(study, ex, "Dask, 2 workers × 1 thread (loopback)", repeats, chunk_size))
                finally:
                    ex.close()
    return rows


def render(rows: list[Row], note: str = "", load: tuple[float, float] | None = None) -> str:
    import os

    load_text = (f" Load average (1 min) {load[0]:.1f} before and {load[1]:.1f} after: other work shared the cores, "
                 "so the pool and Dask rows are lower bounds of what two free cores give." if load else "")
    lines = [
        "# Study throughput: points per second",
        "",
        f"Generated by `python -m bench.bench_studies` on {datetime.date.today()}, {platform.machine()} "
        f"CPython {platform.python_version()}, {os.cpu_count()} cores (shared with other work while measured).",
        "A *study* row is a whole study run by the service's runner: planning, content hashes, chunks on the "
        "executor, results written to a fresh SQLite (WAL) store. The *baseline* evaluates the same points one "
        "by one in this process without a store. Wall time per run (median / p95 over the repeats); the ratio is "
        "points/s against the baseline of the same problem, measured in the same run. *Points per CPU-s* divides "
        "by the CPU time of the processes that evaluated the points (this process, the pool's workers via psutil, "
        "the Dask workers via `client.run`): what one free core gives, whatever else shares the machine; "
        "n free cores give about n times that. `critical_stiffness` is the vectorised problem (optim.critical_study: "
        "a chunk's devices in one `batch_critical_stiffness` call per delay class) over the same wall and sweep as "
        "`stability`; its baseline evaluates it one point at a time (a batch of one)." + load_text,
        "",
        "| problem | executor | points | median [s] | p95 [s] | points/s | ratio vs baseline | points per CPU-s | failed points | points per chunk |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    base = {r.problem: r.rate for r in rows if "baseline" in r.executor}
    for r in rows:
        cpu = f"{r.cpu_rate:.0f}" if r.cpu_rate else "—"
        lines.append(f"| {r.problem} | {r.executor} | {r.points} | {r.median:.3f} | {r.p95:.3f} | {r.rate:.0f} | "
                     f"{r.rate / base[r.problem]:.2f} | {cpu} | {r.failed} | {r.chunk or '—'} |")
    goals = []
    for prob, goal in GOALS.items():
        mine = [r for r in rows if r.problem == prob]
        if mine:
            best = max(r.rate for r in mine)
            per_core = max(r.cpu_rate or 0.0 for r in mine)
            goals.append(f"{prob}: ≥ {goal} points/s — best measured {best:.0f}/s, two free cores ≈ "
                         f"{2 * per_core:.0f}/s ({'met' if best >= goal else 'not met'})")
    lines += ["", "Goals on 2 cores (issue 8): " + "; ".join(goals) + "."]
    stab, crit = base.get("stability"), [r for r in rows if r.problem == "critical_stiffness"]
    if stab and crit:
        best = max(crit, key=lambda r: r.rate)
        lines += ["", f"K_cr of a sweep: the vectorised `critical_stiffness` study ({best.executor}) gives "
                  f"{best.rate:.0f} points/s, {best.rate / stab:.1f} × the one-by-one full `stability` analysis "
                  f"of the same points ({stab:.0f}/s, measured in this run)."]
    if not any(r.problem == "stiffness" for r in rows):
        lines += ["", "Stiffness designs: `optim.stiffness` is not in this build, so the stiffness problem answers "
                  "422 and is not measured here."]
    if note:
        lines += ["", note]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--points", type=int, default=400)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--critical-points", type=int, default=None, help="points of the critical_stiffness study (default 10 × points)")
    ap.add_argument("--stiffness-points", type=int, default=None,
                    help="designs of the stiffness study (default = points: a study long enough that the pool's "
                         "start and the last chunk's tail do not dominate)")
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "docs" / "bench_studies.md"))
    args = ap.parse_args()
    import os

    before = os.getloadavg()[0]
    rows = measure(args.points, args.repeats, dask=not args.no_dask, critical_points=args.critical_points,
                   stiffness_points=args.stiffness_points)
    text = render(rows, load=(before, os.getloadavg()[0]))
    Path(args.out).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
