"""A real zwidth server for the client tests: uvicorn on a free loopback port, started by the CLI's own
``zwidth serve``, once per session, always killed."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest

from bench.live_server import free_port

ROOT = Path(__file__).resolve().parents[2]
#: Keys whose values are wall-clock timings, which differ between any two runs.
TIMING_KEYS = frozenset({"elapsed_ms", "setup_ms", "solve_ms"})


@dataclass
class Server:
    url: str
    process: subprocess.Popen
    token: str | None = None


def start_server(tmp: Path, env_extra: dict[str, str] | None = None, timeout: float = 60.0) -> Server:
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZWIDTH_")}
    # its own study store in its temporary directory, never the user's (tests/conftest.py)
    env.update({"PYTHONPATH": str(ROOT), "ZWIDTH_DATABASE_URL": f"sqlite:///{tmp / 'studies.db'}", **(env_extra or {})})
    log = open(tmp / f"server-{port}.log", "wb")
    # The CLI's `serve` command: the session server doubles as that command's end-to-end test.
    proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
                            cwd=tmp, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"server exited with {proc.returncode}: {(tmp / f'server-{port}.log').read_text()}")
        try:
            if httpx.get(url + "/healthz", timeout=1.0).status_code == 200:
                return Server(url, proc, (env_extra or {}).get("ZWIDTH_API_TOKEN"))
        except httpx.TransportError:
            time.sleep(0.1)
    stop_server(proc)
    raise RuntimeError("server did not answer /healthz in time")


def stop_server(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)   # its own session: uvicorn and any compute workers it started
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)


@pytest.fixture(scope="session")
def server(tmp_path_factory) -> Iterator[Server]:
    srv = start_server(tmp_path_factory.mktemp("server"))
    try:
        yield srv
    finally:
        stop_server(srv.process)


@pytest.fixture(scope="session")
def dead_url() -> str:
    """A loopback URL where nothing listens (connection refused)."""
    return f"http://127.0.0.1:{free_port()}"


def without_timings(value):
    """The answer with wall-clock timings removed (everything else must match exactly)."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


@functools.lru_cache(maxsize=None)
def _openapi() -> dict:
    """The current app's OpenAPI document, built once per session (an app and its document cost about a second:
    test modules ask for routes at collection time, and the fast loop paid it once per question)."""
    from service.app import create_app

    return create_app().openapi()


def openapi_document() -> dict:
    """A copy of the session's OpenAPI document (tests may not change the shared one)."""
    import copy

    return copy.deepcopy(_openapi())


@functools.lru_cache(maxsize=None)
def _routes() -> frozenset[str]:
    return frozenset(_openapi()["paths"])


def has_route(path: str) -> bool:
    """Whether this build of the service has an endpoint (some land on other branches first)."""
    return path in _routes()
