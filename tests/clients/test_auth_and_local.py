"""Bearer tokens against a server that requires one, and the in-process (--local) transports."""

from __future__ import annotations

import asyncio
import importlib.util

import pytest
from typer.testing import CliRunner

from clients import APIError, AsyncZwidthClient, ZwidthClient
from clients.cli import app
from clients.local import AsyncLocalTransport, LocalTransport

from .conftest import start_server, stop_server, without_timings

pytestmark = pytest.mark.slow

AUTH = importlib.util.find_spec("service.auth") is not None
DEVICE = {"preset": "lhifam-reduced-pretension", "delay": 0.0015}


@pytest.fixture(scope="module")
def secured(tmp_path_factory):
    srv = start_server(tmp_path_factory.mktemp("secured"), {"ZWIDTH_API_TOKEN": "lab-token-1"})
    try:
        yield srv
    finally:
        stop_server(srv.process)


@pytest.mark.skipif(not AUTH, reason="bearer auth (service/auth.py, ZWIDTH_API_TOKEN) is not in this build yet "
                                     "(branch service)")
def test_bearer_token_client_and_cli(secured, monkeypatch):
    with ZwidthClient(secured.url) as zw, pytest.raises(APIError) as info:
        zw.stability(DEVICE)
    assert info.value.status == 401
    with ZwidthClient(secured.url, token="lab-token-1") as zw:
        assert zw.stability(DEVICE).critical_stiffness > 0
        assert zw.health().status == "ok"
    runner = CliRunner()
    monkeypatch.delenv("ZWIDTH_API_TOKEN", raising=False)
    assert runner.invoke(app, ["analyze", "lhifam", "--url", secured.url]).exit_code == 3
    assert runner.invoke(app, ["analyze", "lhifam", "--url", secured.url, "--token", "lab-token-1"]).exit_code == 0
    monkeypatch.setenv("ZWIDTH_API_TOKEN", "lab-token-1")
    assert runner.invoke(app, ["analyze", "lhifam", "--url", secured.url]).exit_code == 0


def test_local_transports_answer_like_the_server(server):
    with ZwidthClient(server.url) as remote:
        want = remote.boundary(DEVICE, points=6).model_dump()
    transport = LocalTransport()
    with ZwidthClient(transport=transport) as local:
        got = local.boundary(DEVICE, points=6).model_dump()
    assert without_timings(got) == without_timings(want)

    async def run():
        async with AsyncZwidthClient(transport=AsyncLocalTransport()) as az:
            return (await az.boundary(DEVICE, points=6)).model_dump()
    assert without_timings(asyncio.run(run())) == without_timings(want)


def test_local_app_ignores_a_token_in_the_environment(monkeypatch):
    """--local is not reachable from outside: a lab's ZWIDTH_API_TOKEN must not lock the user out of it."""
    monkeypatch.setenv("ZWIDTH_API_TOKEN", "lab-token-1")
    with ZwidthClient(transport=LocalTransport()) as local:
        assert local.stability(DEVICE).critical_stiffness > 0
