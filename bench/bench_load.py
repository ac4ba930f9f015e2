"""Load: many concurrent clients on loopback mixing analyses and designs against a real server.

Starts ``uvicorn service.app:app`` on a free 127.0.0.1 port, measures the server's
resident memory (all its processes), drives it with N concurrent clients for S
seconds (bounded in count and time), then measures memory again.  Reports errors,
throughput and latency percentiles per kind of request, side by side with the
same requests sent one at a time (the unloaded baseline) in the same run.
Writes docs/bench_load.md.

    python -m bench.bench_load [--clients 50] [--seconds 30] [--workers 2]
"""

from __future__ import annotations

import argparse
import asyncio
import datetime as _dt
import os
import platform
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import numpy as np

RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}
MIX: list[tuple[str, str, dict]] = [
    ("stability rigid", "/v1/analysis/stability", {"device": RIGID}),
    ("stability cable + wall", "/v1/analysis/stability",
     {"device": {"preset": "lhifam", "delay": 0.001}, "controller": {"stiffness": 2000, "damping": 2}}),
    ("boundary (20 points)", "/v1/analysis/boundary", {"device": {**RIGID, "delay": 0.002}, "points": 20}),
    ("design stiffness rigid", "/v1/design/stiffness", {"device": RIGID, "requirements": {"min_gain_margin_db": 6}}),
    ("force feedforward", "/v1/analysis/force-feedforward",
     {"device": {**RIGID, "human": {"mass": 2, "damping": 2, "stiffness": 10}, "force_sensor": {"time_constant": 0.005}}}),
]
# weights: analyses dominate a lab's traffic
WEIGHTS = (6, 3, 1, 1, 2)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _rss_kib(pid: int) -> int:
    """Resident memory of a process and its children [KiB], from /proc."""
    total = 0
    pids = [pid]
    try:
        children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
        pids += [int(c) for c in children]
    except OSError:
        pass
    for p in pids:
        try:
            for line in Path(f"/proc/{p}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
        except OSError:
            continue
    return total


def start_server(port: int, workers: int) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    proc = subprocess.Popen([sys.executable, "-m", "uvicorn", "service.app:app", "--host", "127.0.0.1",
                             "--port", str(port), "--workers", str(workers), "--log-level", "warning"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code == 200:
                return proc
        except httpx.HTTPError:
            time.sleep(0.2)
    proc.kill()
    raise RuntimeError("server did not become healthy within 60 s")


async def _client(base: str, stop_at: float, rng: np.random.Generator, out: dict, max_requests: int) -> None:
    p = np.array(WEIGHTS, dtype=float) / sum(WEIGHTS)
    async with httpx.AsyncClient(base_url=base, timeout=60) as client:
        for _ in range(max_requests):
            if time.monotonic() >= stop_at:
                return
            name, path, body = MIX[int(rng.choice(len(MIX), p=p))]
            t0 = time.perf_counter()
            try:
                r = await client.post(path, json=body)
                ok = r.status_code == 200
            except httpx.HTTPError:
                ok = False
            dt = (time.perf_counter() - t0) * 1e3
            out.setdefault(name, {"ms": [], "errors": 0})
            out[name]["ms"].append(dt)
            out[name]["errors"] += 0 if ok else 1


async def _drive(base: str, clients: int, seconds: float) -> tuple[dict, float]:
    out: dict = {}
    stop_at = time.monotonic() + seconds
    t0 = time.perf_counter()
    await asyncio.gather(*[_client(base, stop_at, np.random.default_rng(i), out, 100_000) for i in range(clients)])
    return out, time.perf_counter() - t0


def _baseline(base: str, repeats: int) -> dict[str, float]:
    res = {}
    with httpx.Client(base_url=base, timeout=60) as c:
        for name, path, body in MIX:
            c.post(path, json=body)
            ts = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                assert c.post(path, json=body).status_code == 200
                ts.append((time.perf_counter() - t0) * 1e3)
            res[name] = float(np.median(ts))
    return res


def run(clients: int = 50, seconds: float = 30.0, workers: int = 2, baseline_repeats: int = 10) -> dict:
    port = free_port()
    proc = start_server(port, workers)
    base = f"http://127.0.0.1:{port}"
    try:
        base_ms = _baseline(base, baseline_repeats)
        rss_before = _rss_kib(proc.pid)
        out, wall = asyncio.run(_drive(base, clients, seconds))
        rss_after = _rss_kib(proc.pid)
        health = httpx.get(f"{base}/healthz", timeout=5).status_code
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
    return {"clients": clients, "seconds": seconds, "workers": workers, "wall": wall, "per_kind": out,
            "baseline_ms": base_ms, "rss_before_kib": rss_before, "rss_after_kib": rss_after, "health_after": health}


def render(res: dict) -> str:
    total = sum(len(v["ms"]) for v in res["per_kind"].values())
    errors = sum(v["errors"] for v in res["per_kind"].values())
    lines = [
        "# Load: concurrent clients on loopback",
        "",
        f"Generated by `python -m bench.bench_load` on {_dt.date.today().isoformat()}, {platform.machine()}, "
        f"CPython {platform.python_version()}, 2 cores shared by server and clients. uvicorn with "
        f"{res['workers']} workers; {res['clients']} concurrent clients for {res['seconds']:.0f} s "
        f"(asyncio + httpx, each client sends its next request when the last is answered).",
        "",
        f"**{total} requests, {errors} errors, {total / res['wall']:.1f} requests/s.** Server memory (RSS of all its "
        f"processes): {res['rss_before_kib'] / 1024:.1f} MiB before, {res['rss_after_kib'] / 1024:.1f} MiB after; "
        f"/healthz after the run: HTTP {res['health_after']}.",
        "",
        "| request | count | errors | p50 ms | p95 ms | p99 ms | max ms | unloaded p50 ms (same run) | p50 ratio loaded/unloaded |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, _, _ in MIX:
        v = res["per_kind"].get(name)
        if not v:
            continue
        ms = np.array(v["ms"])
        b = res["baseline_ms"][name]
        lines.append(f"| {name} | {len(ms)} | {v['errors']} | {np.percentile(ms, 50):.1f} | {np.percentile(ms, 95):.1f} | "
                     f"{np.percentile(ms, 99):.1f} | {ms.max():.1f} | {b:.1f} | {np.percentile(ms, 50) / b:.1f} |")
    lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="docs/bench_load.md")
    args = ap.parse_args(argv)
    text = render(run(args.clients, args.seconds, args.workers))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)
    print(text)
    return text


if __name__ == "__main__":
    main()
