"""A small HTTP/1.1 keep-alive load generator, run as its own process so that it never shares the server's
interpreter: ``python -m bench.loadgen --port P --path /healthz --connections 32 --duration 5``.

The fallback of bench/bench_service.py when ``wrk`` is not installed.  Raw asyncio streams (uvloop when
present), one connection per simulated client, each sending its next request when the previous answer is
read (closed loop, like wrk).  Prints one JSON line: requests, errors (non-2xx or broken connections),
requests/s and the latency percentiles [ms].
"""

from __future__ import annotations

import argparse
import asyncio
import json
import time


def _request(host: str, port: int, method: str, path: str, body: bytes) -> bytes:
    head = f"{method} {path} HTTP/1.1\r\nHost: {host}:{port}\r\n"
    if body:
        head += f"Content-Type: application/json\r\nContent-Length: {len(body)}\r\n"
    return (head + "\r\n").encode() + body


async def _client(host: str, port: int, raw: bytes, stop_at: float, lat: list[float], errors: list[int]) -> None:
    reader, writer = await asyncio.open_connection(host, port)
    try:
        while time.perf_counter() < stop_at:
            t0 = time.perf_counter()
            writer.write(raw)
            status_line = await reader.readline()
            length = 0
            while True:
                line = await reader.readline()
                if line in (b"\r\n", b""):
                    break
                if line[:15].lower() == b"content-length:":
                    length = int(line[15:])
            await reader.readexactly(length)
            lat.append(time.perf_counter() - t0)
            if not status_line.startswith(b"HTTP/1.1 2"):
                errors[0] += 1
    except (OSError, asyncio.IncompleteReadError, ValueError):
        errors[0] += 1
    finally:
        writer.close()


async def _run(host: str, port: int, method: str, path: str, body: bytes, connections: int, duration: float) -> dict:
    raw = _request(host, port, method, path, body)
    lat: list[float] = []
    errors = [0]
    t0 = time.perf_counter()
    await asyncio.gather(*(_client(host, port, raw, t0 + duration, lat, errors) for _ in range(connections)))
    elapsed = time.perf_counter() - t0
    lat.sort()

    def pct(q: float) -> float:
        return 1e3 * lat[min(len(lat) - 1, round(q * (len(lat) - 1)))] if lat else float("nan")

    return {"requests": len(lat), "errors": errors[0], "rps": len(lat) / elapsed, "p50_ms": pct(0.5),
            "p95_ms": pct(0.95)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, required=True)
    ap.add_argument("--path", default="/healthz")
    ap.add_argument("--body", default="", help="JSON body (POST when given)")
    ap.add_argument("--connections", type=int, default=1)
    ap.add_argument("--duration", type=float, default=5.0)
    a = ap.parse_args()
    try:
        import uvloop
        uvloop.install()
    except ImportError:
        pass
    body = a.body.encode()
    print(json.dumps(asyncio.run(_run(a.host, a.port, "POST" if body else "GET", a.path, body, a.connections,
                                      a.duration))))


if __name__ == "__main__":
    main()
