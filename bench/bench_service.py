"""HTTP service benchmark: a live uvicorn serving POST /v1/analysis/stability (rigid, exact) beside /healthz.

In one run, for ``uvicorn --workers 1`` and ``--workers 2`` (each worker with ZWIDTH_COMPUTE_WORKERS=1: the
exact rigid analysis runs inline, so the compute pool only idles, and 2 cores have no room for more):

1. one client, keep-alive, back to back: p50/p95 of the rigid exact analysis and of /healthz;
2. 32 concurrent keep-alive clients: requests/s, errors, p50/p95 of both;
3. the numerics alone (``analyse_stability`` called directly), so the HTTP share is visible;
4. the full exact analysis over HTTP by its own ``elapsed_ms`` (K and B given: K_cr, every crossover, margin,
   passivity, B_max) on the loops of issue 20, beside python-control's ``stability_margins`` on the same loop
   (bench/bench_core.py builds it: ZOH plant, delay, damper closed with ``feedback``) timed in the same run.

The load generator runs in its own process: ``wrk`` when it is installed (``apt-get install wrk``), else
bench/loadgen.py (asyncio, uvloop).  On 2 cores it still shares the CPU with the server, so the throughput is
a lower bound.  Writes docs/bench_service.md.

    PYTHONPATH=. python bench/bench_service.py [--duration 5] [--clients 32] [--workers 1 2] [--out docs/bench_service.md]
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from bench.live_server import ROOT, LiveServer

PATH = "/v1/analysis/stability"
BODY = {"device": {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}}
GOAL_P50_MS = 1.5
GOAL_RPS = 1000.0
GOAL_RATIO = 0.005
#: sleep before each in-process call of the "after a sleep" column [s]
SLEEP_S = 0.0005
#: The loops of issue 20's table: (label, device, B [N·s/m]); T = 1 ms.
LOOPS = [
    ("m=5.4, b=3.5, d=0, B=0", {"mass": 5.4, "damping": 3.5, "delay": 0.0}, 0.0),
    ("m=5.4, b=3.5, d=5, B=20", {"mass": 5.4, "damping": 3.5, "delay": 0.005}, 20.0),
    ("m=1.05e-3, b=0.0085, d=50, B=0", {"mass": 1.05e-3, "damping": 0.0085, "delay": 0.05}, 0.0),
    ("m=1.05e-3, b=0.0085, d=200, B=0.004", {"mass": 1.05e-3, "damping": 0.0085, "delay": 0.2}, 0.004),
]


@dataclass(frozen=True)
class Load:
    label: str
    requests: int
    errors: int
    rps: float
    p50_ms: float
    p95_ms: float


@dataclass(frozen=True)
class LoopRow:
    label: str
    http_elapsed_ms: float     # median elapsed_ms reported by the server
    http_wall_ms: float        # median client wall time of the same requests
    control_ms: float          # median python-control stability_margins
    hot_ms: float = float("nan")   # median of the same analysis called in this process, back to back
    slept_ms: float = float("nan")   # median elapsed_ms of the same call in this process, 0.5 ms of sleep before each


_LUA = """wrk.method = "{method}"
{body}
done = function(summary, latency, requests)
  local e = summary.errors
  io.write(string.format("RESULT %d %d %.1f %.4f %.4f\\n", summary.requests,
    e.connect + e.read + e.write + e.status + e.timeout, summary.duration,
    latency:percentile(50) / 1000, latency:percentile(95) / 1000))
end
"""


def _wrk(port: int, path: str, body: dict | None, connections: int, duration: float) -> tuple:
    lua = _LUA.format(method="POST" if body else "GET",
                      body=(f'wrk.body = [[{json.dumps(body)}]]\nwrk.headers["Content-Type"] = "application/json"'
                            if body else ""))
    with tempfile.NamedTemporaryFile("w", suffix=".lua", delete=False) as f:
        f.write(lua)
    try:
        out = subprocess.run(["wrk", f"-t{min(2, connections)}", f"-c{connections}", f"-d{max(1, round(duration))}s",
                              "--timeout", "10s", "-s", f.name, f"http://127.0.0.1:{port}{path}"],
                             capture_output=True, text=True, timeout=duration + 60, check=True).stdout
    finally:
        os.unlink(f.name)
    n, err, dur_us, p50, p95 = next(line for line in out.splitlines() if line.startswith("RESULT")).split()[1:]
    return int(n), int(err), int(n) / (float(dur_us) * 1e-6), float(p50), float(p95)


def _loadgen(port: int, path: str, body: dict | None, connections: int, duration: float) -> tuple:
    out = subprocess.run([sys.executable, "-m", "bench.loadgen", "--port", str(port), "--path", path,
                          "--body", json.dumps(body) if body else "", "--connections", str(connections),
                          "--duration", str(duration)], capture_output=True, text=True, timeout=duration + 60,
                         check=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}).stdout
    r = json.loads(out.strip().splitlines()[-1])
    return r["requests"], r["errors"], r["rps"], r["p50_ms"], r["p95_ms"]


def tool() -> str:
    return "wrk" if shutil.which("wrk") else "loadgen"


def load(label: str, port: int, path: str, body: dict | None, connections: int, duration: float) -> Load:
    fn = _wrk if tool() == "wrk" else _loadgen
    return Load(label, *fn(port, path, body, connections, duration))


def _post(conn: http.client.HTTPConnection, body: bytes) -> tuple[float, dict]:
    t0 = time.perf_counter()
    conn.request("POST", PATH, body=body, headers={"Content-Type": "application/json"})
    r = conn.getresponse()
    data = r.read()
    dt = time.perf_counter() - t0
    if r.status != 200:
        raise RuntimeError(f"HTTP {r.status}: {data[:200]!r}")
    return dt, json.loads(data)


def _wait_ready(port: int, servers: int, timeout: float = 300.0) -> None:
    """Until every uvicorn worker's compute pool is warm (GET /readyz 200 on 10·servers fresh connections in a
    row, which the kernel spreads over the workers): warming builds the design solvers, seconds of CPU that
    would otherwise fall into the measurement."""
    deadline = time.monotonic() + timeout
    streak = 0
    while streak < 10 * servers:
        if time.monotonic() > deadline:
            raise RuntimeError("the server's compute workers did not warm up in time")
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        try:
            conn.request("GET", "/readyz")
            ok = conn.getresponse().status == 200
        finally:
            conn.close()
        streak = streak + 1 if ok else 0
        if not ok:
            time.sleep(0.2)


def loops_over_http(port: int, repeats: int) -> list[LoopRow]:
    """The full exact analysis (K = K_cr/2 and B given) over HTTP, beside python-control on the same loop."""
    from bench.bench_core import _control_default, _control_system
    from models.device import Device
    from optim.stability.analysis import analyse_stability
    from optim.stability.margins import critical_stiffness

    rows = []
    for label, dev_kw, b in LOOPS:
        # a connection per loop: the in-process timings below outlast uvicorn's keep-alive (5 s) on a loaded machine
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
        try:
            dev = Device(sample_time=1e-3, **dev_kw)
            k = 0.5 * critical_stiffness(dev, b).critical_stiffness
            body = json.dumps({"device": {**dev_kw, "sample_time": 1e-3},
                               "controller": {"stiffness": k, "damping": b}}).encode()
            for _ in range(3):
                _post(conn, body)
            walls, elapsed = [], []
            for _ in range(repeats):
                dt, res = _post(conn, body)
                walls.append(dt * 1e3)
                elapsed.append(res["elapsed_ms"])
        finally:
            conn.close()
        hot = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            analyse_stability(dev, k, b)
            hot.append((time.perf_counter() - t0) * 1e3)
        # as the server runs it: the process slept (on its socket) before each call, so the numerics start with
        # cold caches; elapsed_ms, the server's own measure
        slept = []
        for _ in range(repeats):
            time.sleep(SLEEP_S)
            slept.append(analyse_stability(dev, k, b).elapsed_ms)
        sys_ = _control_system(dev, b)
        _control_default(sys_)
        ctrl = []
        for _ in range(max(3, repeats // 10)):
            t0 = time.perf_counter()
            _control_default(sys_)
            ctrl.append((time.perf_counter() - t0) * 1e3)
        rows.append(LoopRow(label, statistics.median(elapsed), statistics.median(walls), statistics.median(ctrl),
                            statistics.median(hot), statistics.median(slept)))
    return rows


def numerics(n: int) -> tuple[float, float]:
    """(p50, p95) [ms] of the bare numerics call of the benchmarked request, validation of the Device included."""
    from models.device import Device
    from optim.stability.analysis import analyse_stability

    for _ in range(max(20, n // 10)):
        analyse_stability(Device(**BODY["device"]))
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        analyse_stability(Device(**BODY["device"]))
        out.append((time.perf_counter() - t0) * 1e3)
    out.sort()
    return statistics.median(out), out[min(len(out) - 1, round(0.95 * (len(out) - 1)))]


def run(duration: float = 5.0, clients: int = 32, workers: tuple[int, ...] = (1, 2), loop_repeats: int = 100,
        n_numerics: int = 400, out: Path | None = None) -> dict:
    load_before = os.getloadavg()[0]
    loads: dict[int, list[Load]] = {}
    loops: list[LoopRow] = []
    for w in workers:
        server = LiveServer(workers=w, timeout=120.0, env={"ZWIDTH_COMPUTE_WORKERS": "1"})
        try:
            _wait_ready(server.port, w)
            load("warm-up", server.port, PATH, BODY, clients, max(1.0, duration / 5))
            rows = []
            for name, path, body in (("rigid exact analysis", PATH, BODY), ("/healthz", "/healthz", None)):
                rows.append(load(f"{name}, 1 client", server.port, path, body, 1, duration))
                rows.append(load(f"{name}, {clients} clients", server.port, path, body, clients, duration))
            loads[w] = rows
            if not loops:
                loops = loops_over_http(server.port, loop_repeats)
        finally:
            server.stop()
    result = {"loads": loads, "loops": loops, "numerics": numerics(n_numerics), "tool": tool()}
    if out is not None:
        out.write_text(render(result, duration, clients, load_before), encoding="utf-8")
    return result


def render(r: dict, duration: float, clients: int, load_before: float) -> str:
    num50, num95 = r["numerics"]
    rows = []
    for w, loads in r["loads"].items():
        for s in loads:
            rows.append(f"| {w} | {s.label} | {s.requests} | {s.errors} | {s.rps:.0f} | {s.p50_ms:.2f} | {s.p95_ms:.2f} |")
    loop_rows = [f"| {x.label} | {x.http_elapsed_ms:.3f} | {x.http_wall_ms:.2f} | {x.control_ms:.2f} | "
                 f"{x.http_elapsed_ms / x.control_ms:.4f} | {x.hot_ms:.3f} | {x.hot_ms / x.control_ms:.4f} | "
                 f"{x.slept_ms:.3f} | {x.slept_ms / x.control_ms:.4f} |"
                 for x in r["loops"]]
    verdict = []
    for w, loads in r["loads"].items():
        one, many = loads[0], loads[1]
        verdict.append(f"{w} worker{'s' if w > 1 else ''}: p50 {one.p50_ms:.2f} ms "
                       f"{'≤' if one.p50_ms <= GOAL_P50_MS else '>'} {GOAL_P50_MS:g} ms; {many.rps:.0f} requests/s "
                       f"{'≥' if many.rps >= GOAL_RPS else '<'} {GOAL_RPS:g} with {many.errors} errors")
    if r["loops"]:
        ratio = statistics.median(x.http_elapsed_ms / x.control_ms for x in r["loops"])
        verdict.append(f"elapsed_ms / python-control median {ratio:.4f} {'≤' if ratio <= GOAL_RATIO else '>'} "
                       f"{GOAL_RATIO:g}")
    return "\n".join([
        "# Service benchmark: POST /v1/analysis/stability (rigid, exact rung) beside /healthz",
        "",
        (f"Generated by `bench/bench_service.py` on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
        f"{os.cpu_count()} CPUs, Python {platform.python_version()}; a live `uvicorn service.app:app` on loopback "
        f"(ZWIDTH_COMPUTE_WORKERS=1 per uvicorn worker, access log off), keep-alive connections from "
        f"`{r['tool']}` in its own process (on the same cores as the server), {duration:g} s per row. "
        f"Request: `{json.dumps(BODY)}`. The machine is shared: 1-minute load average {load_before:.2f} when the "
        f"run started; numbers from a loaded machine must be rerun on a quiet one."),
        "",
        "| uvicorn workers | request | requests | errors | requests/s | p50 [ms] | p95 [ms] |",
        "|---:|---|---:|---:|---:|---:|---:|",
        *rows,
        (f"| — | numerics alone: `analyse_stability` called directly (Device validation included) | — | — | — | "
        f"{num50:.3f} | {num95:.3f} |"),
        "",
        ("The /healthz rows are the HTTP floor (uvicorn, middlewares, routing, JSON); the difference to the analysis "
        "rows is the numerics plus the request's validation and serialisation."),
        "",
        "## The full exact analysis over HTTP against python-control",
        "",
        ("K = K_cr/2 and B given (K_cr, every crossover, margin, passivity with delay, B_max when B > 0); "
        "`elapsed_ms` is the server's own timing of the analysis, the wall time is the client's; python-control: "
        "one `stability_margins` on the same loop (bench/bench_core.py builds it), timed in this run, back to back. "
        "The back-to-back columns time the same `analyse_stability` call back to back in the benchmark's own "
        "process; the last two its own `elapsed_ms` with a 0.5 ms sleep before each call, in the same process: a "
        "server answering one request at a time computes each analysis after its process slept on the socket, and "
        "the numerics then start with cold caches (a tight loop of the same length loses ~3 µs to the sleep, the "
        "analysis, with its larger code path, tens of µs)."),
        "",
        ("| loop (T = 1 ms) | elapsed_ms median | HTTP wall median [ms] | python-control [ms] | elapsed / python-control "
         "| back to back [ms] | back to back / python-control | after a 0.5 ms sleep [ms] | after a sleep / python-control |"),
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        *loop_rows,
        "",
        f"**Goals** (2 cores): one client p50 ≤ {GOAL_P50_MS:g} ms; ≥ {GOAL_RPS:g} requests/s with {clients} "
        f"clients and no errors; elapsed_ms median ≤ {GOAL_RATIO:g}× python-control. **Measured**: "
        + "; ".join(verdict) + ".",
        "",
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=5.0, help="seconds per load row")
    ap.add_argument("--clients", type=int, default=32, help="concurrent clients of the throughput rows")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="uvicorn worker counts to measure")
    ap.add_argument("--repeats", type=int, default=100, help="HTTP requests per loop of the python-control table")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "bench_service.md")
    a = ap.parse_args()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    run(a.duration, a.clients, tuple(a.workers), a.repeats, out=a.out)
    print(a.out.read_text(encoding="utf-8"))


if __name__ == "__main__":
    main()
