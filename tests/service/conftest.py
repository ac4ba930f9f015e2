"""Fixtures of the HTTP tests: in-process apps (TestClient) and a real uvicorn process on loopback."""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import pytest
from fastapi.testclient import TestClient

from bench.live_server import LiveServer
from service.app import create_app
from service.settings import Settings

ROOT = Path(__file__).resolve().parents[2]

#: The rigid LHifAM of the chapter's Table 2/3 (copied from the chapter, not read from ../shared).
LHIFAM_RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}


def make_client(**settings) -> TestClient:
    """A TestClient on a fresh app; ``settings`` override the defaults (no environment read for them)."""
    settings.setdefault("prestart_workers", False)  # most tests never need a worker process
    return TestClient(create_app(Settings(**settings)), raise_server_exceptions=False)


@pytest.fixture
def client() -> Iterator[TestClient]:
    with make_client() as c:  # the context runs the lifespan: compute workers are shut down at the end
        yield c


def start_live_server(env: dict[str, str] | None = None) -> LiveServer:
    """``uvicorn service.app:app`` on a free loopback port, healthy (bench/live_server.py, shared with bench/)."""
    return LiveServer(env, timeout=30.0)


@pytest.fixture(scope="module")
def live_server() -> Iterator[LiveServer]:
    server = start_live_server()
    try:
        yield server
    finally:
        server.stop()
