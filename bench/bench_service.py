"""HTTP service benchmark: latency and throughput of POST /v1/analysis/stability over loopback.

Starts ``python -m uvicorn service.app:app`` on a free port, then measures in the same run:

1. one client, sequential requests (latency without queueing),
2. C concurrent clients (threads, one keep-alive connection each) for D seconds (throughput),
3. comparators: the same request through starlette's TestClient in-process (no socket, no HTTP
   parsing by uvicorn) and the bare numerics call ``optim.stability.analysis.analyse_stability``.

The request is the rigid LHifAM (chapter Table 2), exact rung: the service's fast path.  Clients use
the standard library's http.client rather than httpx: on a 2-core machine the load generator shares the
CPU with the server, and a lighter client disturbs the measurement less.  Writes docs/bench_service.md.

    PYTHONPATH=. python bench/bench_service.py [--duration 8] [--clients 4] [--out docs/bench_service.md]
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import platform
import statistics
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from bench.live_server import ROOT, LiveServer
PATH = "/v1/analysis/stability"
BODY = {"device": {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}}
GOAL_P50_MS = 5.0
GOAL_RPS = 300.0


@dataclass(frozen=True)
class Stats:
    label: str
    n: int
    p50_ms: float
    p95_ms: float
    throughput: float | None  # requests/s, when measured under load


def _pct(samples: list[float], q: float) -> float:
    s = sorted(samples)
    return s[min(len(s) - 1, int(round(q * (len(s) - 1))))]


def _stats(label: str, samples: list[float], throughput: float | None = None) -> Stats:
    return Stats(label, len(samples), 1e3 * statistics.median(samples), 1e3 * _pct(samples, 0.95), throughput)


def _post(conn: http.client.HTTPConnection, payload: bytes) -> float:
    t0 = time.perf_counter()
    conn.request("POST", PATH, body=payload, headers={"Content-Type": "application/json"})
    r = conn.getresponse()
    data = r.read()
    dt = time.perf_counter() - t0
    if r.status != 200:
        raise RuntimeError(f"HTTP {r.status}: {data[:200]!r}")
    return dt


def sequential(port: int, n: int) -> list[float]:
    payload = json.dumps(BODY).encode()
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    try:
        for _ in range(max(20, n // 10)):  # warm-up: imports, caches, connection
            _post(conn, payload)
        return [_post(conn, payload) for _ in range(n)]
    finally:
        conn.close()


def concurrent(port: int, clients: int, duration: float) -> tuple[list[float], float]:
    payload = json.dumps(BODY).encode()
    samples: list[list[float]] = [[] for _ in range(clients)]
    start = threading.Barrier(clients + 1)
    stop_at = [0.0]

    def client(i: int) -> None:
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        _post(conn, payload)
        start.wait()
        while time.perf_counter() < stop_at[0]:
            samples[i].append(_post(conn, payload))
        conn.close()

    threads = [threading.Thread(target=client, args=(i,)) for i in range(clients)]
    for t in threads:
        t.start()
    t0 = time.perf_counter()
    stop_at[0] = t0 + duration
    start.wait()
    for t in threads:
        t.join()
    elapsed = time.perf_counter() - t0
    flat = [s for per in samples for s in per]
    return flat, len(flat) / elapsed


def in_process(n: int) -> list[float]:
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # starlette's httpx2 notice
        from fastapi.testclient import TestClient

    from service.app import create_app
    from service.settings import Settings

    with TestClient(create_app(Settings(prestart_workers=False, access_log=False))) as c:
        for _ in range(max(20, n // 10)):
            c.post(PATH, json=BODY)
        out = []
        for _ in range(n):
            t0 = time.perf_counter()
            r = c.post(PATH, json=BODY)
            out.append(time.perf_counter() - t0)
            assert r.status_code == 200
    return out


def numerics(n: int) -> list[float]:
    from models.device import Device
    from optim.stability.analysis import analyse_stability

    out = []
    for _ in range(max(20, n // 10)):
        analyse_stability(Device(**BODY["device"]))
    for _ in range(n):
        t0 = time.perf_counter()
        analyse_stability(Device(**BODY["device"]))  # validation included, as the service does it
        out.append(time.perf_counter() - t0)
    return out


def run(duration: float = 8.0, clients: int = 4, n_seq: int = 400, out: Path | None = None) -> dict[str, Stats]:
    load_before = os.getloadavg()[0]
    server = LiveServer(timeout=30.0)
    try:
        seq = _stats("uvicorn, 1 client (sequential)", sequential(server.port, n_seq))
        flat, rps = concurrent(server.port, clients, duration)
        load = _stats(f"uvicorn, {clients} concurrent clients, {duration:g} s", flat, rps)
    finally:
        server.stop()
    tc = _stats("comparator: TestClient in-process (no socket)", in_process(n_seq))
    core = _stats("comparator: analyse_stability direct call", numerics(n_seq))
    result = {"sequential": seq, "load": load, "testclient": tc, "numerics": core}
    if out is not None:
        out.write_text(render(result, duration, clients, load_before), encoding="utf-8")
    return result


def render(r: dict[str, Stats], duration: float, clients: int, load_before: float) -> str:
    core = r["numerics"].p50_ms
    rows = []
    for key in ("sequential", "load", "testclient", "numerics"):
        s = r[key]
        thr = f"{s.throughput:.0f}" if s.throughput is not None else "—"
        rows.append(f"| {s.label} | {s.n} | {s.p50_ms:.2f} | {s.p95_ms:.2f} | {thr} | {s.p50_ms / core:.2f} |")
    seq, load = r["sequential"], r["load"]
    verdict = (f"p50 {seq.p50_ms:.2f} ms (one client) {'≤' if seq.p50_ms <= GOAL_P50_MS else '>'} {GOAL_P50_MS:g} ms goal; "
               f"{load.throughput:.0f} requests/s under load {'≥' if load.throughput >= GOAL_RPS else '<'} "
               f"{GOAL_RPS:g} goal.")
    return "\n".join([
        "# Service benchmark: POST /v1/analysis/stability (rigid LHifAM, exact rung)",
        "",
        f"Generated by `bench/bench_service.py` on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
        f"{os.cpu_count()} CPUs, Python {platform.python_version()}; one uvicorn worker process on loopback, "
        f"keep-alive connections (stdlib http.client clients in threads, on the same cores as the server). "
        f"Latency is client-side wall time per request. The machine is shared: 1-minute load average "
        f"{load_before:.2f} when the run started.",
        "",
        "| path | requests | p50 [ms] | p95 [ms] | throughput [req/s] | p50 / numerics p50 |",
        "|---|---:|---:|---:|---:|---:|",
        *rows,
        "",
        f"**Goal** (2 cores): p50 ≤ {GOAL_P50_MS:g} ms and ≥ {GOAL_RPS:g} requests/s. **Measured**: {verdict}",
        "",
        "The numerics comparator includes building the `Device` (validation) and the whole ladder answer "
        "(K_cr, crossovers, linear estimate); the difference to the TestClient row is FastAPI's request "
        "validation and response serialisation, and the difference to the uvicorn rows is HTTP over the socket. "
        "Cheap analyses run inline in the request thread (service/cost.py); only calls estimated above 25 ms "
        "pay the ~1 ms round trip to a worker process (service/executor.py).",
        "",
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=8.0, help="seconds of concurrent load")
    ap.add_argument("--clients", type=int, default=4, help="concurrent clients")
    ap.add_argument("--requests", type=int, default=400, help="sequential requests per comparator")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "bench_service.md")
    a = ap.parse_args()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    r = run(a.duration, a.clients, a.requests, a.out)
    print(a.out.read_text(encoding="utf-8"))
    del r


if __name__ == "__main__":
    main()
