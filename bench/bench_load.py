"""Load: many clients mixing heavy and cheap requests against one live server; health, latency and memory.

Starts ``uvicorn service.app:app`` (one server process, its compute workers) on a free loopback port, waits
for ``/readyz``, measures the server's resident memory, then drives it for S seconds with N concurrent
clients (asyncio + httpx) mixing

* heavy requests, which the service runs in its compute workers under the request time budget: a
  boundary, reference-rung analyses (mpmath), Bode and boundary plots;
* cheap requests, which it runs inline: exact analyses of rigid and cable devices, a force feedforward.

Each client sends its next request when the last is answered; after a 503 it first waits the answer's
``Retry-After`` (as a client should: the service sheds load so that it is honoured).

Meanwhile a separate process probes ``/healthz`` every 50 ms (its own event loop: the probe's latency is
the server's, not the load generator's), and the queue is sampled from ``/readyz``.  After the clients
stop, the server's memory is measured again once its queue is empty.  Issue 18's targets, checked and
printed:

* ``/healthz`` p99 ≤ 200 ms;
* cheap analyses p99 ≤ 500 ms;
* every heavy request answers 200, or 503 within budget + 1 s (shed at once past the queue depth, or at the
  budget); nothing else, and no transport error;
* the server process's RSS after the run within 100 MB of before.

Writes docs/bench_load.md.

    python -m bench.bench_load [--clients 64] [--seconds 60] [--budget 30] [--compute-workers 2]
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
#: (name, kind, path, body, weight): heavy requests run in a compute worker, cheap ones inline.
MIX: list[tuple[str, str, str, dict, int]] = [
    ("stability rigid", "cheap", "/v1/analysis/stability", {"device": RIGID}, 6),
    ("stability cable + wall", "cheap", "/v1/analysis/stability",
     {"device": {"preset": "lhifam", "delay": 0.001}, "controller": {"stiffness": 2000, "damping": 2}}, 3),
    ("force feedforward", "cheap", "/v1/analysis/force-feedforward",
     {"device": {**RIGID, "human": {"mass": 2, "damping": 2, "stiffness": 10},
                 "force_sensor": {"time_constant": 0.005}}}, 2),
    ("boundary (50 points, 5 ms delay)", "heavy", "/v1/analysis/boundary",
     {"device": {**RIGID, "delay": 0.005}, "points": 50}, 2),
    ("stability reference (mpmath)", "heavy", "/v1/analysis/stability",
     {"device": {**RIGID, "delay": 0.002}, "method": "reference"}, 2),
    ("bode plot (0.5 s delay, 2000 points)", "heavy", "/v1/plots/bode",
     {"device": {"preset": "lhifam", "delay": 0.5}, "points": 2000, "format": "svg"}, 1),
    ("boundary plot (20 points)", "heavy", "/v1/plots/boundary", {"device": RIGID, "points": 20}, 1),
]
HEALTH_P99_MS = 200.0
CHEAP_P99_MS = 500.0
HEAVY_SLACK_S = 1.0
RSS_GROWTH_MB = 100.0


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
    weights = np.array([m[4] for m in MIX], dtype=float)
    p = weights / weights.sum()
    while time.monotonic() < stop_at:
        name, kind, path, body, _ = MIX[int(rng.choice(len(MIX), p=p))]
        t0 = time.perf_counter()
        retry_after = 0.0
        try:
            r = await client.post(path, json=body)
            status = r.status_code
            if status == 503:
                retry_after = float(r.headers.get("retry-after", 0))
        except httpx.HTTPError as exc:
            status = type(exc).__name__
        rec = out.setdefault(name, {"kind": kind, "ms": [], "status": {}})
        rec["ms"].append((time.perf_counter() - t0) * 1e3)
        rec["status"][status] = rec["status"].get(status, 0) + 1
        if status == 503:
            rec.setdefault("ms_503", []).append(rec["ms"][-1])
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


def run(clients: int = 64, seconds: float = 60.0, budget: float = 30.0, compute_workers: int = 2,
        queue_depth: int | None = None) -> dict:
    env = {"ZWIDTH_REQUEST_TIMEOUT": str(budget), "ZWIDTH_COMPUTE_WORKERS": str(compute_workers),
           "ZWIDTH_DASK_SCHEDULER": None}
    if queue_depth is not None:
        env["ZWIDTH_COMPUTE_QUEUE"] = str(queue_depth)
    server = LiveServer(env=env, ready_path="/readyz", timeout=180)
    base = server.url
    try:
        # one of each first: imports and caches of the server process are not growth under load
        with httpx.Client(base_url=base, timeout=budget + 30) as c:
            for _, _, path, body, _ in MIX:
                c.post(path, json=body)
        _wait_idle(base)
        rss_before = rss_kib(server.pid)
        total_before = sum(rss_kib(p) for p in session_pids(server.pid))
        parent, child = multiprocessing.get_context("spawn").Pipe(duplex=False)
        prober = multiprocessing.get_context("spawn").Process(target=_probe, args=(base, seconds, 0.05, child))
        prober.start()
        per_kind, queue, wall = asyncio.run(_drive(base, clients, seconds))
        health_ms = parent.recv() if parent.poll(budget + 60) else []
        prober.join(10)
        _wait_idle(base)
        time.sleep(1.0)
        rss_after = rss_kib(server.pid)
        total_after = sum(rss_kib(p) for p in session_pids(server.pid))
        health_after = httpx.get(f"{base}/healthz", timeout=5).status_code
    finally:
        server.stop()
    return {"clients": clients, "seconds": seconds, "budget": budget, "compute_workers": compute_workers,
            "queue_depth": queue_depth, "wall": wall, "per_kind": per_kind, "health_ms": health_ms, "queue": queue,
            "rss_before_kib": rss_before, "rss_after_kib": rss_after, "total_before_kib": total_before,
            "total_after_kib": total_after, "health_after": health_after}


def verdicts(res: dict) -> dict[str, tuple[bool, str]]:
    """Issue 18's targets: name -> (met, what was measured)."""
    health = np.array(res["health_ms"] or [float("inf")])
    cheap = np.concatenate([v["ms"] for v in res["per_kind"].values() if v["kind"] == "cheap"] or [[np.inf]])
    cheap_bad = sum(n for v in res["per_kind"].values() if v["kind"] == "cheap"
                    for s, n in v["status"].items() if s != 200)
    limit_ms = (res["budget"] + HEAVY_SLACK_S) * 1e3
    heavy_other = sum(n for v in res["per_kind"].values() if v["kind"] == "heavy"
                      for s, n in v["status"].items() if s not in (200, 503))
    heavy_late = sum(1 for v in res["per_kind"].values() if v["kind"] == "heavy"
                     for ms in v.get("ms_503", []) if ms > limit_ms)
    heavy_n = sum(len(v["ms"]) for v in res["per_kind"].values() if v["kind"] == "heavy")
    growth = (res["rss_after_kib"] - res["rss_before_kib"]) / 1024
    return {
        "/healthz p99 ≤ 200 ms": (bool(np.percentile(health, 99) <= HEALTH_P99_MS),
                                  f"p99 {np.percentile(health, 99):.1f} ms over {len(res['health_ms'])} probes"),
        "cheap analyses p99 ≤ 500 ms, all 200": (bool(np.percentile(cheap, 99) <= CHEAP_P99_MS and cheap_bad == 0),
                                                 f"p99 {np.percentile(cheap, 99):.1f} ms, {cheap_bad} not 200"),
        f"heavy: 200, or 503 within budget + {HEAVY_SLACK_S:g} s": (
            heavy_other == 0 and heavy_late == 0 and heavy_n > 0,
            f"{heavy_n} heavy requests: {heavy_other} neither 200 nor 503, {heavy_late} 503 later than "
            f"{limit_ms / 1e3:g} s"),
        "server RSS after within 100 MB of before": (growth <= RSS_GROWTH_MB, f"{growth:+.1f} MB"),
    }


def _pct(ms, q) -> str:
    return f"{np.percentile(ms, q):.1f}" if len(ms) else "–"


def render(res: dict) -> str:
    kinds = res["per_kind"]
    total = sum(len(v["ms"]) for v in kinds.values())
    depth = max((d for d, _ in res["queue"]), default=0)
    lines = [
        "# Load: heavy and cheap requests from many clients, health and memory (issue 18)",
        "",
        f"Generated by `python -m bench.bench_load` on {_dt.date.today().isoformat()}, {platform.machine()}, "
        f"CPython {platform.python_version()}, 2 cores shared by the server, its compute workers and the clients. "
        f"One uvicorn process with {res['compute_workers']} compute workers, request budget {res['budget']:g} s, "
        f"queue depth {res['queue_depth'] if res['queue_depth'] is not None else 'default'}; {res['clients']} "
        f"concurrent clients for {res['seconds']:g} s (asyncio + httpx, each sends its next request when the last "
        f"is answered, after the `Retry-After` of a 503); /healthz probed every 50 ms from a separate process.",
        "",
        f"**{total} requests in {res['wall']:.1f} s ({total / res['wall']:.1f}/s).** Deepest queue seen on /readyz: "
        f"{depth}. Server process RSS {res['rss_before_kib'] / 1024:.1f} MiB before, "
        f"{res['rss_after_kib'] / 1024:.1f} MiB after (all its processes: {res['total_before_kib'] / 1024:.1f} → "
        f"{res['total_after_kib'] / 1024:.1f} MiB); /healthz after the run: HTTP {res['health_after']}.",
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
    lines += ["", "Heavy requests answer 503 with `Retry-After` when the queue is full (at once) or at the budget; "
              "see docs/limits.md.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clients", type=int, default=64)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--budget", type=float, default=30.0, help="ZWIDTH_REQUEST_TIMEOUT of the server [s]")
    ap.add_argument("--compute-workers", type=int, default=2)
    ap.add_argument("--queue-depth", type=int, default=None, help="ZWIDTH_COMPUTE_QUEUE (default: the service's)")
    ap.add_argument("--out", default="docs/bench_load.md")
    args = ap.parse_args(argv)
    text = render(run(args.clients, args.seconds, args.budget, args.compute_workers, args.queue_depth))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)
    print(text)
    return text


if __name__ == "__main__":
    main()
