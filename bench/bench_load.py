"""Load: many clients mixing heavy and cheap requests against a live ``--workers N`` server; deadlines, errors,
health and memory (issues 18 and 28).

Starts ``uvicorn service.app:app --workers N`` (N server processes on one port, each with its compute workers,
their study store a fresh SQLite file) on a free loopback port, waits for ``/readyz``, sends each request once
(the warm-up), measures the resident memory of every process of the server, then drives it for S seconds
with C concurrent clients (asyncio + httpx) mixing

* heavy requests, run in the compute workers under the request time budget: robust stiffness designs,
  reference-rung analyses (mpmath), a boundary, Bode and boundary plots, a long simulation;
* cheap requests, run inline: exact analyses of rigid and cable devices, a force feedforward, a short
  simulation;
* studies: a 12-point study submitted (202, or 429 past ZWIDTH_STUDY_MAX_ACTIVE), and its status read.

Each client sends its next request when the last is answered; after a 503 or 429 it first waits the answer's
``Retry-After`` (as a client should).

Meanwhile a separate process probes ``/healthz`` every 50 ms (its own event loop: the probe's latency is
the server's, not the load generator's), and the queue is sampled from ``/readyz``.  After the clients
stop and the queues drain, memory is measured again.  Issue 28's targets, checked and printed:

* 0 answers later than the request budget + 2 s;
* 0 answers 5xx other than 503 with ``Retry-After`` (and no transport error);
* ``/healthz`` p99 ≤ 200 ms;
* the server's RSS (all its processes) after the run ≤ 1.2 × its RSS after the warm-up.

Writes docs/bench_load.md, with the machine's load average before and after.

    python -m bench.bench_load [--clients 64] [--seconds 60] [--budget 10] [--workers 2] [--compute-workers 1]
"""

from __future__ import annotations

import argparse
import asyncio
import datetime as _dt
import multiprocessing
import platform
import time
from pathlib import Path

import httpx
import numpy as np

from bench.live_server import LiveServer, rss_kib, session_pids

RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
_STUDY = {"problem": "stability", "base": {"device": RIGID, "requirements": {"stiffness": 2000}},
          "sweep": {"device.delay": {"num": 4, "start": 0, "stop": 0.003}, "requirements.damping": [0, 5, 10]}}
#: (name, kind, method, path, body, weight): heavy requests run in a compute worker, cheap ones inline.
MIX: list[tuple[str, str, str, str, dict | None, int]] = [
    ("stability rigid", "cheap", "POST", "/v1/analysis/stability", {"device": RIGID}, 6),
    ("stability cable + wall", "cheap", "POST", "/v1/analysis/stability",
     {"device": {"preset": "lhifam", "delay": 0.001}, "controller": {"stiffness": 2000, "damping": 2}}, 3),
    ("force feedforward", "cheap", "POST", "/v1/analysis/force-feedforward",
     {"device": {**RIGID, "human": {"mass": 2, "damping": 2, "stiffness": 10},
                 "force_sensor": {"time_constant": 0.005}}}, 2),
    ("simulation (release, 1 s)", "cheap", "POST", "/v1/simulate",
     {"device": RIGID, "scene": {"controller": {"stiffness": 2000}, "duration": 1.0, "experiment": "release",
                                 "initial": {"position": 0.001}}}, 2),
    ("robust design (mass × delay box)", "heavy", "POST", "/v1/design/stiffness",
     {"device": {"preset": "lhifam", "cable": None},
      "requirements": {"uncertainty": {"device.mass": {"min": 4, "max": 7}, "device.delay": {"min": 0, "max": 0.002}}}},
     2),
    ("stability reference (mpmath)", "heavy", "POST", "/v1/analysis/stability",
     {"device": {**RIGID, "delay": 0.002}, "method": "reference"}, 2),
    ("boundary (50 points, 5 ms delay)", "heavy", "POST", "/v1/analysis/boundary",
     {"device": {**RIGID, "delay": 0.005}, "points": 50}, 1),
    ("bode plot (0.5 s delay, 2000 points)", "heavy", "POST", "/v1/plots/bode",
     {"device": {"preset": "lhifam", "delay": 0.5}, "points": 2000, "format": "svg"}, 1),
    ("boundary plot (20 points)", "heavy", "POST", "/v1/plots/boundary", {"device": RIGID, "points": 20}, 1),
    ("simulation plot (lhifam, 5 s)", "heavy", "POST", "/v1/plots/simulation",
     {"device": {"preset": "lhifam"}, "scene": {"controller": {"stiffness": 6500}, "duration": 5.0,
                                                "experiment": "release", "initial": {"position": 0.001}}}, 1),
    ("study submit (12 points)", "study", "POST", "/v1/studies", _STUDY, 1),
    ("study list", "study", "GET", "/v1/studies?limit=20", None, 1),
]
HEALTH_P99_MS = 200.0
#: An answer may come this long after the request budget [s] (issue 28).
LATE_SLACK_S = 2.0
RSS_GROWTH_FACTOR = 1.2


def _probe(url: str, seconds: float, interval: float, conn) -> None:
    """In its own process: GET /healthz every ``interval`` s for ``seconds``; sends back the latencies [ms]
    (a failed probe counts as +inf)."""
    out: list[float] = []
    stop_at = time.monotonic() + seconds
    with httpx.Client(base_url=url, timeout=30) as c:
        while time.monotonic() < stop_at:
            t0 = time.perf_counter()
            try:
                ok = c.get("/healthz").status_code == 200
            except httpx.HTTPError:
                ok = False
            out.append((time.perf_counter() - t0) * 1e3 if ok else float("inf"))
            time.sleep(max(0.0, interval - (time.perf_counter() - t0)))
    conn.send(out)
    conn.close()


async def _client(client: httpx.AsyncClient, stop_at: float, rng: np.random.Generator, out: dict) -> None:
    weights = np.array([m[5] for m in MIX], dtype=float)
    p = weights / weights.sum()
    while time.monotonic() < stop_at:
        name, kind, method, path, body, _ = MIX[int(rng.choice(len(MIX), p=p))]
        t0 = time.perf_counter()
        retry_after = 0.0
        has_retry = False
        try:
            r = await client.request(method, path, json=body)
            status = r.status_code
            has_retry = "retry-after" in r.headers
            if status in (429, 503):
                retry_after = float(r.headers.get("retry-after", 0))
        except httpx.HTTPError as exc:
            status = type(exc).__name__
        rec = out.setdefault(name, {"kind": kind, "ms": [], "status": {}})
        rec["ms"].append((time.perf_counter() - t0) * 1e3)
        rec["status"][status] = rec["status"].get(status, 0) + 1
        if isinstance(status, int) and status >= 500 and not (status == 503 and has_retry):
            rec["bad_5xx"] = rec.get("bad_5xx", 0) + 1
        if status in (429, 503):
            await asyncio.sleep(retry_after)   # a polite client: what Retry-After is for


async def _sample_queue(base: str, stop_at: float, out: list) -> None:
    async with httpx.AsyncClient(base_url=base, timeout=30, verify=False) as client:
        while time.monotonic() < stop_at:
            try:
                q = (await client.get("/readyz")).json()["queue"]
                out.append((q["depth"], q["busy"]))
            except (httpx.HTTPError, KeyError, ValueError):
                pass
            await asyncio.sleep(0.25)


async def _drive(base: str, clients: int, seconds: float) -> tuple[dict, list, float]:
    out: dict = {}
    queue: list = []
    # One client, one connection per simulated client: an AsyncClient each would load the CA bundle each
    # (tens of ms of the load generator's loop, counted in the first requests' latency).
    limits = httpx.Limits(max_connections=clients, max_keepalive_connections=clients)
    async with httpx.AsyncClient(base_url=base, timeout=600, limits=limits, verify=False) as client:
        stop_at = time.monotonic() + seconds
        t0 = time.perf_counter()
        await asyncio.gather(_sample_queue(base, stop_at, queue),
                             *[_client(client, stop_at, np.random.default_rng(i), out) for i in range(clients)])
        return out, queue, time.perf_counter() - t0


def _wait_idle(base: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        q = httpx.get(f"{base}/readyz", timeout=10).json()["queue"]
        if q["depth"] == 0 and q["busy"] == 0:
            return
        time.sleep(0.1)


def _load() -> str:
    import os

    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def run(clients: int = 64, seconds: float = 60.0, budget: float = 10.0, workers: int = 2, compute_workers: int = 1,
        queue_depth: int | None = None) -> dict:
    import tempfile

    store = Path(tempfile.mkdtemp(prefix="zwidth-bench-load-")) / "studies.db"
    env = {"ZWIDTH_REQUEST_TIMEOUT": str(budget), "ZWIDTH_COMPUTE_WORKERS": str(compute_workers),
           "ZWIDTH_DASK_SCHEDULER": None, "ZWIDTH_DATABASE_URL": f"sqlite:///{store}", "ZWIDTH_STUDY_WORKERS": "1"}
    if queue_depth is not None:
        env["ZWIDTH_COMPUTE_QUEUE"] = str(queue_depth)
    load_before = _load()
    server = LiveServer(env=env, workers=workers, ready_path="/readyz", timeout=300)
    base = server.url
    try:
        # each request a few times first (every uvicorn worker gets some): imports, caches and compiled kernels
        # are not growth under load
        with httpx.Client(base_url=base, timeout=budget + 30) as c:
            for _ in range(2 * workers):
                for _, _, method, path, body, _ in MIX:
                    c.request(method, path, json=body, headers={"connection": "close"})
        _wait_idle(base)
        time.sleep(2.0)
        total_before = sum(rss_kib(p) for p in session_pids(server.pid))
        parent, child = multiprocessing.get_context("spawn").Pipe(duplex=False)
        prober = multiprocessing.get_context("spawn").Process(target=_probe, args=(base, seconds, 0.05, child))
        prober.start()
        per_kind, queue, wall = asyncio.run(_drive(base, clients, seconds))
        health_ms = parent.recv() if parent.poll(budget + 60) else []
        prober.join(10)
        _wait_idle(base)
        time.sleep(2.0)
        total_after = sum(rss_kib(p) for p in session_pids(server.pid))
        health_after = httpx.get(f"{base}/healthz", timeout=5).status_code
    finally:
        server.stop()
    return {"clients": clients, "seconds": seconds, "budget": budget, "workers": workers,
            "compute_workers": compute_workers, "queue_depth": queue_depth, "wall": wall, "per_kind": per_kind,
            "health_ms": health_ms, "queue": queue, "total_before_kib": total_before, "total_after_kib": total_after,
            "health_after": health_after, "load_before": load_before, "load_after": _load()}


def verdicts(res: dict) -> dict[str, tuple[bool, str]]:
    """Issue 28's targets: name -> (met, what was measured)."""
    health = np.array(res["health_ms"] or [float("inf")])
    limit_ms = (res["budget"] + LATE_SLACK_S) * 1e3
    every = [ms for v in res["per_kind"].values() for ms in v["ms"]]
    late = sum(1 for ms in every if ms > limit_ms)
    worst = max(every, default=float("nan"))
    bad_5xx = sum(v.get("bad_5xx", 0) for v in res["per_kind"].values())
    transport = sum(n for v in res["per_kind"].values() for s, n in v["status"].items() if not isinstance(s, int))
    ratio = res["total_after_kib"] / max(res["total_before_kib"], 1)
    return {
        f"0 answers later than budget + {LATE_SLACK_S:g} s": (
            late == 0, f"{late} of {len(every)} later than {limit_ms / 1e3:g} s (slowest {worst / 1e3:.2f} s)"),
        "0 5xx other than 503 with Retry-After, 0 transport errors": (
            bad_5xx == 0 and transport == 0, f"{bad_5xx} other 5xx, {transport} transport errors"),
        f"/healthz p99 ≤ {HEALTH_P99_MS:g} ms": (bool(np.percentile(health, 99) <= HEALTH_P99_MS),
                                               f"p99 {np.percentile(health, 99):.1f} ms over {len(res['health_ms'])} "
                                               "probes"),
        f"RSS after ≤ {RSS_GROWTH_FACTOR:g} × RSS after warm-up": (
            ratio <= RSS_GROWTH_FACTOR, f"{res['total_before_kib'] / 1024:.1f} → {res['total_after_kib'] / 1024:.1f} "
                                        f"MiB (× {ratio:.3f}), every process of the server"),
    }


def _pct(ms, q) -> str:
    return f"{np.percentile(ms, q):.1f}" if len(ms) else "–"


def render(res: dict) -> str:
    kinds = res["per_kind"]
    total = sum(len(v["ms"]) for v in kinds.values())
    depth = max((d for d, _ in res["queue"]), default=0)
    lines = [
        f"# Load: a --workers {res['workers']} server under {res['clients']} mixed clients; deadlines, errors, health "
        "and memory (issue 28)",
        "",
        f"Generated by `python -m bench.bench_load` on {_dt.date.today().isoformat()}, {platform.machine()}, "
        f"CPython {platform.python_version()}, 2 cores shared by the server, its compute workers, the clients "
        f"**and the other sessions on the machine: load average (1/5/15 min) {res['load_before']} before, "
        f"{res['load_after']} after**. `uvicorn --workers {res['workers']}` (each worker with "
        f"{res['compute_workers']} compute worker(s) and the study runner; store: a fresh SQLite file), request "
        f"budget {res['budget']:g} s, queue depth {res['queue_depth'] if res['queue_depth'] is not None else 'default'}; "
        f"{res['clients']} concurrent clients for {res['seconds']:g} s (asyncio + httpx, each sends its next request "
        f"when the last is answered, after the `Retry-After` of a 503 or 429); /healthz probed every 50 ms from a "
        f"separate process.",
        "",
        f"**{total} requests in {res['wall']:.1f} s ({total / res['wall']:.1f}/s).** Deepest compute queue seen on "
        f"/readyz (of the worker that answered): {depth}. /healthz after the run: HTTP {res['health_after']}.",
        "",
        "| target | met | measured |",
        "|---|---|---|",
    ]
    for name, (ok, what) in verdicts(res).items():
        lines.append(f"| {name} | {'yes' if ok else '**no**'} | {what} |")
    lines += ["", "| request | kind | count | answers | p50 ms | p95 ms | p99 ms | max ms |", "|---|---|---|---|---|---|---|---|"]
    health = res["health_ms"]
    lines.append(f"| GET /healthz (probe) | – | {len(health)} | – | {_pct(health, 50)} | {_pct(health, 95)} | "
                 f"{_pct(health, 99)} | {max(health, default=float('nan')):.1f} |")
    for name, kind, *_ in MIX:
        v = kinds.get(name)
        if not v:
            continue
        ms = np.array(v["ms"])
        answers = ", ".join(f"{n}× {s}" for s, n in sorted(v["status"].items(), key=lambda x: str(x[0])))
        lines.append(f"| {name} | {kind} | {len(ms)} | {answers} | {_pct(ms, 50)} | {_pct(ms, 95)} | "
                     f"{_pct(ms, 99)} | {ms.max():.1f} |")
    lines += ["", "Heavy requests answer 503 with `Retry-After` when the compute queue is full (at once) or at the "
              "budget; a study past ZWIDTH_STUDY_MAX_ACTIVE active ones answers 429 with `Retry-After`; see "
              "docs/limits.md.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clients", type=int, default=64)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--budget", type=float, default=10.0, help="ZWIDTH_REQUEST_TIMEOUT of the server [s]")
    ap.add_argument("--workers", type=int, default=2, help="uvicorn worker processes")
    ap.add_argument("--compute-workers", type=int, default=1, help="compute workers of each uvicorn worker")
    ap.add_argument("--queue-depth", type=int, default=None, help="ZWIDTH_COMPUTE_QUEUE (default: the service's)")
    ap.add_argument("--out", default="docs/bench_load.md")
    args = ap.parse_args(argv)
    text = render(run(args.clients, args.seconds, args.budget, args.workers, args.compute_workers, args.queue_depth))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)
    print(text)
    return text


if __name__ == "__main__":
    main()
