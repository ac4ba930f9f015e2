"""Against a real uvicorn process on a free loopback port: health, presets, one analysis per preset,
bit-exact answers, and a server that survives oversized, truncated and malformed requests."""

from __future__ import annotations

import json
import socket
import time

import httpx
import pytest

from models.device import PRESETS

from .conftest import LHIFAM_RIGID, start_live_server
from .test_analysis_routes import assert_same, expected_stability

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def raw_exchange(port: int, payload: bytes, read_timeout: float = 10.0, shut_write: bool = False) -> bytes:
    """Send raw bytes, return whatever the server answers before it closes or goes quiet."""
    with socket.create_connection(("127.0.0.1", port), timeout=read_timeout) as s:
        s.sendall(payload)
        if shut_write:
            s.shutdown(socket.SHUT_WR)
        chunks = []
        try:
            while True:
                data = s.recv(65536)
                if not data:
                    break
                chunks.append(data)
                if b"\r\n\r\n" in b"".join(chunks) and not shut_write:
                    head, _, body = b"".join(chunks).partition(b"\r\n\r\n")
                    length = [int(h.split(b":")[1]) for h in head.split(b"\r\n") if h.lower().startswith(b"content-length")]
                    if length and len(body) >= length[0]:
                        break
        except (socket.timeout, ConnectionResetError):
            pass
    return b"".join(chunks)


def test_health(live_server):
    r = httpx.get(live_server.url + "/healthz")
    assert r.status_code == 200 and r.json()["status"] == "ok"
    assert r.headers["x-request-id"]


def test_presets(live_server):
    r = httpx.get(live_server.url + "/v1/presets")
    assert r.status_code == 200
    assert set(r.json()) == set(PRESETS)
    assert r.json()["lhifam"]["cable"]["stiffness"] == 79500.0  # chapter Table 2


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_one_analysis_per_preset_matches_the_core_bit_for_bit(live_server, preset):
    body = {"device": {"preset": preset}, "controller": {"stiffness": 5.0 if preset == "phantom-1.0" else 3000.0,
                                                         "damping": 0.0}}
    r = httpx.post(live_server.url + "/v1/analysis/stability", json=body)
    assert r.status_code == 200, r.text
    assert_same(r.json(), expected_stability({"preset": preset}, body["controller"]["stiffness"], 0.0))


def test_boundary_over_the_wire(live_server):
    r = httpx.post(live_server.url + "/v1/analysis/boundary", json={"device": LHIFAM_RIGID, "points": 10}, timeout=30)
    assert r.status_code == 200 and len(r.json()["points"]) == 10


def test_ten_megabyte_body_is_refused_without_being_read(live_server):
    """Declare 10 MB, send 64 kB: the 413 arrives at once, so the server never waited for the rest."""
    head = (b"POST /v1/analysis/stability HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            b"Content-Length: 10000000\r\n\r\n")
    t0 = time.monotonic()
    answer = raw_exchange(live_server.port, head + b" " * 65536)
    assert answer.startswith(b"HTTP/1.1 413"), answer[:200]
    assert b"ZWIDTH_MAX_BODY_BYTES" in answer
    assert time.monotonic() - t0 < 5


def test_ten_megabyte_chunked_body_is_refused_midstream(live_server):
    head = (b"POST /v1/analysis/stability HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            b"Transfer-Encoding: chunked\r\n\r\n")
    chunk = b"%x\r\n" % 100_000 + b" " * 100_000 + b"\r\n"
    with socket.create_connection(("127.0.0.1", live_server.port), timeout=10) as s:
        s.sendall(head)
        sent = 0
        answer = b""
        try:
            for _ in range(100):  # 10 MB if the server kept reading
                s.sendall(chunk)
                sent += 1
                s.settimeout(0.001)
                try:
                    answer += s.recv(65536)
                except (socket.timeout, BlockingIOError):
                    pass
                s.settimeout(10)
                if answer:
                    break
        except (BrokenPipeError, ConnectionResetError):
            pass
        if not answer:
            try:
                answer = s.recv(65536)
            except (ConnectionResetError, socket.timeout):
                pass
    assert answer.startswith(b"HTTP/1.1 413"), answer[:200]
    assert sent < 100


def test_httpx_client_gets_413_for_a_big_body(live_server):
    r = httpx.post(live_server.url + "/v1/analysis/stability", content=b"[" + b"1," * 600_000 + b"1]",
                   headers={"content-type": "application/json"})
    assert r.status_code == 413


@pytest.mark.parametrize("payload", [
    # Body shorter than its Content-Length, then the client goes away.
    b"POST /v1/analysis/stability HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 500\r\n\r\n"
    b'{"device": {"mass": 5.4',
    # Headers never finished.
    b"POST /v1/analysis/stability HTTP/1.1\r\nHost: x\r\nContent-Le",
    # Not HTTP at all.
    b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03" + bytes(range(200)),
    b"GARBAGE / HTTP/9.9\r\n\r\n",
    # A bad Content-Length.
    b"POST /v1/analysis/stability HTTP/1.1\r\nHost: x\r\nContent-Length: -5\r\n\r\n",
    # Chunked encoding that lies.
    b"POST /v1/analysis/stability HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\nabc\r\n",
])
def test_malformed_and_truncated_requests_do_not_break_the_server(live_server, payload):
    answer = raw_exchange(live_server.port, payload, read_timeout=3.0, shut_write=True)
    assert not answer.startswith(b"HTTP/1.1 5"), answer[:200]
    r = httpx.post(live_server.url + "/v1/analysis/stability", json={"device": LHIFAM_RIGID})
    assert r.status_code == 200 and r.json()["critical_stiffness"] > 0


def test_non_finite_literals_over_the_wire(live_server):
    text = '{"device": {"mass": NaN, "damping": 1e400}}'
    r = httpx.post(live_server.url + "/v1/analysis/stability", content=text,
                   headers={"content-type": "application/json"})
    assert r.status_code == 422
    assert {tuple(e["loc"]) for e in r.json()["detail"]} >= {("body", "device", "mass"), ("body", "device", "damping")}
    json.loads(r.text)


def test_auth_on_a_live_server():
    server = start_live_server({"ZWIDTH_API_TOKEN": "live-token", "ZWIDTH_PRESTART_WORKERS": "false"})
    try:
        url = server.url + "/v1/presets"
        assert httpx.get(url).status_code == 401
        assert httpx.get(url, headers={"authorization": "Bearer nope"}).status_code == 401
        assert httpx.get(url, headers={"authorization": "Bearer live-token"}).status_code == 200
        assert httpx.get(server.url + "/healthz").status_code == 200
    finally:
        server.stop()
