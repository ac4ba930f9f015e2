"""Study throughput: points per second of whole studies (planner, executor, store) against the
single-point baseline (the same evaluations one by one in this process, no store), side by side.

    PYTHONPATH=. python -m bench.bench_studies          # writes docs/bench_studies.md
    PYTHONPATH=. python -m bench.bench_studies --huge   # also a 10-million-point study on a local Dask cluster

Each configuration runs the same study ``repeats`` times on a fresh SQLite store; the pool (or
the Dask cluster) is started and warmed before timing, as a running service's would be.

The second table (issue 20) goes through the HTTP contract: a live uvicorn server with 2 local workers
(or a local Dask cluster of 2 single-thread workers), a mass × delay grid with delays of 0 … 20 samples
submitted with POST /v1/studies, timed from the study's ``started_at`` to its ``finished_at``, with the
service process's peak RSS (VmHWM) and the sampled peak of the server and its pool together.
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

from models.device import Device
from optim.stability.analysis import analyse_stability
from optim.studies.problems import VECTOR_CHUNK_FACTOR, ProblemUnavailable, evaluate_point, get_problem
from service.studies.executors import DaskExecutor, LocalExecutor
from service.studies.runner import StudyRunner, plan_from_request
from service.studies.store import StudyStore

ROOT = Path(__file__).resolve().parents[1]
#: Throughput goals of issue 8 on 2 cores [points/s].
GOALS = {"stability": 2000, "critical_stiffness": 2000, "stiffness": 200}


def stability_study(points: int) -> dict:
    """Rigid LHifAM wall (K = 1500 N/m) over delay × virtual damping: every point a full exact analysis."""
    n_delay = max(1, points // 4)
    return {"problem": "stability", "base": {"device": {"mass": 5.4, "damping": 3.5}, "requirements": {"stiffness": 1500.0}},
            "sweep": {"device.delay": {"start": 0.0, "stop": 0.004, "num": n_delay},
                      "requirements.damping": [0.0, 2.0, 5.0, 10.0]}}


def critical_study(points: int) -> dict:
    """The stability study's wall and sweep, on the vectorised K_cr problem (a whole chunk per batch)."""
    return {**stability_study(points), "problem": "critical_stiffness"}


def grid_study(problem: str, points: int) -> dict:
    """Issue 20's study: mass × delay (0 … 20 whole samples at T = 1 ms) on a wall K = 1500 N/m, B = 2 N·s/m."""
    n_mass = max(1, points // 21)
    return {"problem": problem,
            "base": {"device": {"mass": 5.4, "damping": 3.5, "sample_time": 0.001},
                     "requirements": {"stiffness": 1500.0, "damping": 2.0}},
            "sweep": {"device.mass": {"start": 0.5, "stop": 10.0, "num": n_mass},
                      "device.delay": [i * 0.001 for i in range(21)]}}


def fractional_study(problem: str, points: int, seed: int = 0) -> dict:
    """Issue 32's study: 400 random masses (0.5 … 10 kg) × fractional delays (0 … 20 ms at T = 1 ms: points/400 of
    them evenly spaced, nearly all a fraction of a sample), the wall of grid_study."""
    n_mass = min(400, max(1, points))
    masses = [float(x) for x in np.random.default_rng(seed).uniform(0.5, 10.0, n_mass)]
    return {"problem": problem,
            "base": {"device": {"mass": 5.4, "damping": 3.5, "sample_time": 0.001},
                     "requirements": {"stiffness": 1500.0, "damping": 2.0}},
            "sweep": {"device.mass": masses,
                      "device.delay": {"start": 0.0, "stop": 0.02, "num": max(1, points // n_mass)}}}


#: the cable grid's cable dampings (device.cable.damping, 2 … 30 N·s/m evenly) and whole delays (0 … 20 samples)
CABLE_DAMPINGS, CABLE_DELAYS = 50, 21


def cable_study(problem: str, points: int) -> dict:
    """Issue 32's cable study: the lhifam preset (two-mass cable, T = 1 ms) over cable stiffness (20 … 120 kN/m,
    points/1050 of them) × delay (0 … 20 whole samples) × cable damping (50 of them, 2 … 30 N·s/m), the wall of
    grid_study.  Every (cable stiffness, cable damping) pair is its own modal factoring; its 21 delays share it."""
    n_k = max(1, points // (CABLE_DELAYS * CABLE_DAMPINGS))
    return {"problem": problem,
            "base": {"device": {"preset": "lhifam"}, "requirements": {"stiffness": 1500.0, "damping": 2.0}},
            "sweep": {"device.cable.stiffness": {"start": 20000.0, "stop": 120000.0, "num": n_k},
                      "device.delay": [i * 0.001 for i in range(CABLE_DELAYS)],
                      "device.cable.damping": {"start": 2.0, "stop": 30.0, "num": CABLE_DAMPINGS}}}


GRIDS = {"whole": grid_study, "fractional": fractional_study, "cable": cable_study}


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


def _previous_stability(device: dict, req: dict) -> tuple[dict | None, str | None]:
    """The previous version's stability point: one full exact ``analyse_stability`` per point (no batch)."""
    try:
        analyse_stability(Device.model_validate(device), req.get("stiffness"), float(req.get("damping") or 0.0),
                          "exact")
        return {}, None
    except ValueError as exc:
        return None, str(exc)


#: the baseline of each problem: the per-point path the study is measured against, side by side
BASELINES = {
    "stability": ("previous version: one analyse_stability per point, in-process", _previous_stability),
    "critical_stiffness": ("previous version: one analyse_stability per point, in-process", _previous_stability),
}


def _baseline(study: dict, repeats: int) -> Row:
    plan = plan_from_request(study)
    inputs = [plan.inputs(v) for v in plan.values(0, plan.total).tolist()]
    label, fn = BASELINES.get(plan.problem, ("single point, in-process (baseline)",
                                             lambda dev, req: evaluate_point(plan.problem, dev, req)))
    fn(*inputs[0])  # imports and caches outside the timing
    times, cpus, failed = [], [], 0
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        failed = sum(fn(dev, req)[1] is not None for dev, req in inputs)
        times.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    return Row(plan.problem, label, plan.total, tuple(times), failed, statistics.median(cpus))


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
               runner.chunk_size_for(plan.problem))


def measure(points: int = 400, repeats: int = 3, workers: tuple[int, ...] = (1, 2), dask: bool = True,
            chunk_size: int = 64, analysis_points: int | None = None, critical_dask: bool = False) -> list[Row]:
    """``points`` stiffness designs; ``analysis_points`` (default 10 × points) for the two vectorised analysis
    problems.  ``chunk_size`` is the runner's (the service's default 64); vectorised problems take their
    ``chunk_factor`` times it (optim.studies.problems)."""
    n_analysis = analysis_points or 10 * points
    studies = [(stability_study(n_analysis), chunk_size, dask),
               (critical_study(n_analysis), chunk_size, dask and critical_dask)]
    try:
        get_problem("stiffness")
        studies.append((stiffness_study(max(2, points)), chunk_size, dask))
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


@dataclass(frozen=True)
class HttpRow:
    problem: str
    executor: str
    points: int
    seconds: float
    """started_at → finished_at of the study as GET /v1/studies/{id} reports it [s]."""
    failed: int
    service_peak_mib: float
    """VmHWM of the service process (the coordinator: plans, hashes, writes) [MiB]."""
    all_peak_mib: float | None
    """sampled peak of the service and its local pool together [MiB] (None with Dask: workers elsewhere)."""
    chunk: int
    cpu: float | None = None
    """CPU time of the service, its pool or the Dask workers during the study [s]."""
    grid: str = "whole"
    """the study's grid (GRIDS): integer delays (grid_study) or fractional ones (fractional_study)."""

    @property
    def rate(self) -> float:
        return self.points / self.seconds

    @property
    def cpu_rate(self) -> float | None:
        """points per CPU-second of every process that worked on the study (server and workers)."""
        return self.points / self.cpu if self.cpu else None


def _peak_kib(pid: int) -> int:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def _cpu_seconds(srv, dask_address: str | None) -> float:
    """CPU seconds used so far by the server's session (server, its pool) and, with Dask, the cluster's workers."""
    import psutil

    total = 0.0
    for pid in srv.session_pids():
        try:
            total += sum(psutil.Process(pid).cpu_times()[:4])
        except psutil.Error:
            pass
    if dask_address:
        from distributed import Client

        with Client(dask_address, set_as_default=False, timeout=30) as c:
            total += sum(c.run(time.process_time).values())
    return total


def _submit_and_wait(client, srv, study: dict, timeout: float) -> tuple[dict, int]:
    """(final status, sampled peak RSS of the server's session [KiB])."""
    from bench.live_server import rss_kib

    r = client.post("/v1/studies", json=study)
    r.raise_for_status()
    sid = r.json()["id"]
    deadline = time.monotonic() + timeout
    peak = 0
    while True:
        st = client.get(f"/v1/studies/{sid}").json()
        peak = max(peak, sum(rss_kib(p) for p in srv.session_pids()))
        if st["status"] not in ("queued", "running", "cancelling"):
            return st, peak
        if time.monotonic() > deadline:
            raise RuntimeError(f"study {sid} not finished after {timeout} s: {st}")
        time.sleep(0.2)


def http_study(problem: str, points: int, dask_address: str | None = None, timeout: float = 3600.0,
               max_points: int | None = None, grid: str = "whole", port: int | None = None) -> HttpRow:
    """One study through a live server's HTTP contract (warmed by a small study first)."""
    import httpx

    from bench.live_server import LiveServer
    from optim.studies.problems import VECTOR_CHUNK_FACTOR
    from service.studies.config import StudySettings

    with tempfile.TemporaryDirectory() as tmp:
        env = {"ZWIDTH_DATABASE_URL": f"sqlite:///{tmp}/studies.db", "ZWIDTH_STUDY_WORKERS": "2",
               "ZWIDTH_DASK_SCHEDULER": dask_address, "ZWIDTH_STUDY_MAX_POINTS": str(max_points or 1_000_000)}
        srv = LiveServer(env, ready_path="/v1/studies", timeout=180, port=port)
        try:
            with httpx.Client(base_url=srv.url, timeout=120) as client:
                _submit_and_wait(client, srv, GRIDS[grid](problem, 2100), timeout)   # pool or cluster warm
                c0 = _cpu_seconds(srv, dask_address)
                st, peak = _submit_and_wait(client, srv, GRIDS[grid](problem, points), timeout)
                cpu = _cpu_seconds(srv, dask_address) - c0
                hwm = _peak_kib(srv.pid)
        finally:
            srv.stop()
    if st["status"] != "done":
        raise RuntimeError(f"{problem} study ended {st['status']}: {st['error']}")
    label = "Dask, 2 workers × 1 thread (loopback)" if dask_address else "local pool, 2 workers"
    return HttpRow(problem, label, st["total"], st["finished_at"] - st["started_at"], st["failed"], hwm / 1024,
                   None if dask_address else peak / 1024,
                   StudySettings().chunk_size * VECTOR_CHUNK_FACTOR * (DaskExecutor.task_scale if dask_address else 1),
                   cpu, grid)


def measure_http(points: int, dask: bool = True, port: int | None = None,
                 grids: tuple[str, ...] = tuple(GRIDS)) -> list[HttpRow]:
    rows = []
    for problem in ("critical_stiffness", "stability"):
        for grid in grids:       # issue 32: any grid, and the cable one
            rows.append(http_study(problem, points, grid=grid, port=port))
        if dask and "whole" in grids:
            from bench.dask_cluster import local_dask_cluster

            with local_dask_cluster(workers=2) as address:
                rows.append(http_study(problem, points, address))
    return rows


#: issue 20's targets through the HTTP contract, 2 workers [points/s]
HTTP_GOALS = {"critical_stiffness": 300_000, "stability": 50_000}
#: issue 32's targets on the cable grid
CABLE_GOALS = {"critical_stiffness": 20_000, "stability": 5_000}


def render_http(rows: list[HttpRow]) -> str:
    lines = ["", "## Through the HTTP contract (issue 20)", "",
             "A live `uvicorn service.app:app` (one process) with `ZWIDTH_STUDY_WORKERS=2` or a local Dask cluster "
             "(2 workers × 1 thread); a mass × delay grid (delays 0 … 20 samples, T = 1 ms; wall K = 1500 N/m, "
             "B = 2 N·s/m) submitted by POST /v1/studies after a warm-up study, points/s from the study's "
             "`started_at` to its `finished_at`. *Service peak RSS* is the server process's VmHWM (it plans chunks "
             "and writes one block per chunk); *with pool* is the sampled peak of the server and its worker processes. "
             "*Points per CPU-s* divides by the CPU time of every process that worked on the study during it (the "
             "server and its pool, or the server and the Dask workers): on a loaded machine the workers (nice 10) get "
             "a fraction of the cores, so this, times the 2 cores, is what two free cores would give.",
             "",
             "",
             "*Grid*: `whole` is that mass × delay grid; `fractional` (issue 32) is 400 random masses (0.5 … 10 kg) × "
             "delays evenly spaced on 0 … 20 ms (2,500 of them for 1M points: nearly every delay a fraction of a "
             "sample, so every plant has the two-zero numerator of a fractional delay), the same wall. `cable` "
             "(issue 32) is the `lhifam` preset (two-mass cable) over device.cable.stiffness (20 … 120 kN/m, 952 of "
             "them for 1M points) × device.delay (0 … 20 whole samples) × device.cable.damping (50 of them, 2 … 30 "
             "N·s/m), the same wall: every (cable stiffness, cable damping) pair is its own modal factoring, shared by "
             "its 21 delays (optim.studies.cable_chunks); its targets are issue 32's (≥ 20,000 points/s for "
             "`critical_stiffness`, ≥ 5,000 for `stability`).",
             "",
             "To rerun this table alone (a few minutes on an idle 2-core machine; the in-process table above is kept): "
             "`PYTHONPATH=. python -m bench.bench_studies --no-runner --no-dask --http-points 1000000` "
             "(`--grids cable` for the cable grid alone).",
             "",
             "| problem | grid | executor | points | started → finished [s] | points/s | target | points per CPU-s "
             "| failed | service peak RSS [MiB] | with pool [MiB] | largest chunk |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        pool = f"{r.all_peak_mib:.0f}" if r.all_peak_mib is not None else "—"
        goal = (CABLE_GOALS if r.grid == "cable" else HTTP_GOALS).get(r.problem)
        cpu = f"{r.cpu_rate:.0f}" if r.cpu_rate else "—"
        lines.append(f"| {r.problem} | {r.grid} | {r.executor} | {r.points} | {r.seconds:.2f} | {r.rate:.0f} | "
                     f"{'≥ %d' % goal if goal else '—'} | {cpu} | {r.failed} | {r.service_peak_mib:.0f} | {pool} | "
                     f"{r.chunk} |")
    for r in rows:
        if r.grid == "cable" and r.cpu_rate:
            goal = CABLE_GOALS[r.problem]
            lines += ["", f"{r.problem}, cable grid: {r.rate:.0f} points/s measured ({'met' if r.rate >= goal else 'not met'}"
                      f" against ≥ {goal}); {r.cpu_rate:.0f} points per CPU-s of the server and its pool, so two free "
                      f"cores ≈ {2 * r.cpu_rate:.0f} points/s."]
    for prob in HTTP_GOALS:
        whole = [r for r in rows if r.problem == prob and r.grid == "whole" and r.cpu_rate and r.all_peak_mib]
        frac = [r for r in rows if r.problem == prob and r.grid == "fractional" and r.cpu_rate and r.all_peak_mib]
        if whole and frac:
            lines += ["", f"{prob}: the fractional grid at {frac[0].cpu_rate / whole[0].cpu_rate:.2f} × the whole "
                      "grid's points per CPU-s (local pool, same run)."]
        local = [r for r in rows if r.problem == prob and r.all_peak_mib is not None and r.grid == "whole"]
        dask = [r for r in rows if r.problem == prob and r.all_peak_mib is None and r.grid == "whole"]
        if local and dask:
            lines += ["", f"{prob}: Dask at {dask[0].rate / local[0].rate:.2f} × local (target within 25 %: "
                      f"{'met' if dask[0].rate >= 0.75 * local[0].rate else 'not met'})."]
    return "\n".join(lines) + "\n"


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
        "executor, results written to a fresh SQLite (WAL) store (the runner's chunk of 64 points, times the "
        f"problem's chunk_factor: {VECTOR_CHUNK_FACTOR} for the vectorised analyses). The *baseline* (points per chunk —) evaluates "
        "the same points one by one in this process without a store: for `stability` and `critical_stiffness` "
        "the previous version's path, one full exact `analyse_stability` per point. Wall time per run (median / p95 over the repeats); the ratio is "
        "points/s against the baseline of the same problem, measured in the same run. *Points per CPU-s* divides "
        "by the CPU time of the processes that evaluated the points (this process, the pool's workers via psutil, "
        "the Dask workers via `client.run`): what one free core gives, whatever else shares the machine; "
        "n free cores give about n times that. Both analysis problems are vectorised over a chunk: `stability` "
        "(optim.studies.stability_study: K_cr, B_max, margin, passivity, eq. 10, Q and the rigid comparison of every "
        "point) and `critical_stiffness` (optim.studies.critical_study: the boundary alone), over the same wall and "
        "sweep." + load_text,
        "",
        "| problem | executor | points | median [s] | p95 [s] | points/s | ratio vs baseline | points per CPU-s | failed points | points per chunk |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    base = {r.problem: r.rate for r in rows if r.chunk is None}
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
    stab = [r for r in rows if r.problem == "stability" and r.chunk is not None]
    if stab and "stability" in base:
        best = max(stab, key=lambda r: r.rate)
        lines += ["", f"Stability sweeps: the vectorised `stability` study ({best.executor}) gives {best.rate:.0f} "
                  f"points/s, {best.rate / base['stability']:.1f} × the previous version's one-by-one full analysis "
                  f"of the same points ({base['stability']:.0f}/s, measured in this run)."]
    if not any(r.problem == "stiffness" for r in rows):
        lines += ["", "Stiffness designs: `optim.stiffness` is not in this build, so the stiffness problem answers "
                  "422 and is not measured here."]
    if note:
        lines += ["", note]
    return "\n".join(lines) + "\n"


def _utc_now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--points", type=int, default=400,
                    help="designs of the stiffness study (long enough that the pool's start and the last chunk's "
                         "tail do not dominate)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--analysis-points", type=int, default=None,
                    help="points of the stability and critical_stiffness studies (default 10 × points)")
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--http-points", type=int, default=210_000,
                    help="points of the mass × delay studies through the HTTP contract (0: skip that table)")
    ap.add_argument("--no-runner", action="store_true", help="skip the in-process runner table")
    ap.add_argument("--grids", default=",".join(GRIDS),
                    help=f"comma-separated grids of the HTTP table, of {', '.join(GRIDS)} (default: all)")
    ap.add_argument("--port", type=int, default=None, help="the live server's loopback port (default: a free one)")
    ap.add_argument("--huge", type=int, nargs="?", const=10_000_000, default=None,
                    help="also a study of this many points (default 10 million) on a local Dask cluster, peak RSS "
                         "printed")
    ap.add_argument("--out", default=str(ROOT / "docs" / "bench_studies.md"))
    args = ap.parse_args()
    import os

    before = os.getloadavg()[0]
    text = ""
    if not args.no_runner:
        rows = measure(args.points, args.repeats, dask=not args.no_dask, analysis_points=args.analysis_points)
        text = render(rows, load=(before, os.getloadavg()[0]))
    if args.http_points:
        before = os.getloadavg()[0]
        grids = tuple(g.strip() for g in args.grids.split(",") if g.strip())
        unknown = [g for g in grids if g not in GRIDS]
        if unknown:
            ap.error(f"--grids: unknown grid(s) {', '.join(unknown)}; known: {', '.join(GRIDS)}")
        http_rows = measure_http(args.http_points, dask=not args.no_dask, port=args.port, grids=grids)
        if args.huge:
            from bench.dask_cluster import local_dask_cluster

            with local_dask_cluster(workers=2) as address:
                huge = http_study("critical_stiffness", args.huge, address, timeout=24 * 3600.0, max_points=args.huge)
            http_rows.append(huge)
            print(f"huge study: {huge.points} points in {huge.seconds:.1f} s ({huge.rate:.0f}/s), service peak RSS "
                  f"{huge.service_peak_mib:.0f} MiB (bound 1024 MiB: {'met' if huge.service_peak_mib <= 1024 else 'not met'})")
        text += render_http(http_rows) + (f"\nLoad average (1 min) {before:.1f} before and {os.getloadavg()[0]:.1f} "
                                          f"after the HTTP runs ({_utc_now()} UTC).\n")
    if args.no_runner and Path(args.out).exists():    # keep the runner table already in the file
        old = Path(args.out).read_text()
        text = old.split("\n## Through the HTTP contract", 1)[0].rstrip("\n") + "\n" + text
    Path(args.out).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
