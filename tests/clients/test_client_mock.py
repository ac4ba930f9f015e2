"""The client's request building, timeouts, retries and error mapping, with httpx.MockTransport (no network)."""

from __future__ import annotations

import asyncio
import json

import httpx
import pytest

import clients
from clients import (
    APIError,
    AsyncZwidthClient,
    ProtocolError,
    Retries,
    Timeouts,
    TransportError,
    ValidationFailed,
    ZwidthClient,
    ZwidthError,
    calls,
)
from models.device import Device

HEALTH = {"status": "ok", "version": "9.9.9"}
FAST = Retries(attempts=3, backoff=0.0)


class Recorder:
    """A mock server: answers with ``reply(request)`` and keeps every request it saw."""

    def __init__(self, reply):
        self.reply = reply
        self.requests: list[httpx.Request] = []

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.requests.append(request)
        return self.reply(request)


def client(reply, **kw) -> tuple[ZwidthClient, Recorder]:
    rec = Recorder(reply)
    return ZwidthClient("http://zw.test", transport=httpx.MockTransport(rec), retries=FAST, **kw), rec


def test_public_names():
    assert sorted(clients.__all__) == sorted([
        "ZwidthClient", "AsyncZwidthClient", "Timeouts", "Retries", "DEFAULT_URL", "Call", "Plot",
        "ZwidthError", "TransportError", "APIError", "ValidationFailed", "ProtocolError"])
    for name in clients.__all__:
        assert getattr(clients, name) is not None


def test_exception_tree():
    assert issubclass(TransportError, ZwidthError) and issubclass(APIError, ZwidthError)
    assert issubclass(ValidationFailed, APIError) and issubclass(ProtocolError, ZwidthError)
    assert issubclass(ValidationFailed, ValueError) and issubclass(TransportError, ConnectionError)
    assert not issubclass(ValidationFailed, TransportError)


def test_both_clients_expose_the_same_methods_with_the_builders_signatures():
    import inspect

    names = [n for n in calls.__all__ if n not in ("Call", "Kind", "Plot", "Export", "device_json")]
    for name in names:
        build = getattr(calls, name)
        for cls in (ZwidthClient, AsyncZwidthClient):
            method = getattr(cls, name)
            assert inspect.signature(method) == inspect.signature(build), (cls.__name__, name)
            assert method.__doc__ == build.__doc__
        assert inspect.iscoroutinefunction(getattr(AsyncZwidthClient, name))


def test_request_body_bearer_token_and_timeout_per_kind():
    zw, rec = client(lambda r: httpx.Response(200, json={"status": "x"}), token="s3cret",
                     timeouts=Timeouts(health=1.5, analysis=42.0, design=99.0, connect=2.0))
    with pytest.raises(ProtocolError):       # the mock's answer is not a StabilityResponse
        zw.stability({"preset": "lhifam"}, {"stiffness": 1000}, method="linear")
    req = rec.requests[0]
    assert req.method == "POST" and req.url.path == "/v1/analysis/stability"
    assert req.headers["authorization"] == "Bearer s3cret"
    assert req.headers["content-type"] == "application/json"
    # arguments left None are not sent: the server's defaults apply
    assert json.loads(req.content) == {"device": {"preset": "lhifam"}, "controller": {"stiffness": 1000},
                                       "method": "linear"}
    assert req.extensions["timeout"] == {"connect": 2.0, "read": 42.0, "write": 42.0, "pool": 42.0}
    zw.send(calls.Call("GET", "/healthz", "design", lambda r: None))
    assert rec.requests[1].extensions["timeout"]["read"] == 99.0


def test_health_has_its_own_short_timeout():
    zw, rec = client(lambda r: httpx.Response(200, json=HEALTH))
    h = zw.health()
    assert h.version == "9.9.9"
    t = rec.requests[0].extensions["timeout"]
    assert t["read"] == Timeouts().health < Timeouts().analysis < Timeouts().design


def test_no_token_no_header():
    zw, rec = client(lambda r: httpx.Response(200, json=HEALTH))
    zw.health()
    assert "authorization" not in rec.requests[0].headers


def test_device_model_is_sent_resolved_without_its_preset():
    body = calls.stability(Device(preset="lhifam", cable=None)).json
    dev = body["device"]
    assert "preset" not in dev and dev["cable"] is None and dev["mass"] == 5.4
    assert dev["human"] == {"mass": 2.0, "damping": 2.0, "stiffness": 10.0}


def test_device_json_takes_a_mapping_a_client_model_or_anything_with_model_dump():
    """A mapping is sent as given; a model (the server's Device, the client's, or any object with pydantic's
    model_dump) is sent resolved without its preset name."""
    assert calls.device_json({"preset": "lhifam", "delay": 1e-3}) == {"preset": "lhifam", "delay": 1e-3}
    server = Device(preset="lhifam", cable=None)
    client = clients.schemas.Device.model_validate(server.model_dump(mode="json"))
    assert calls.device_json(client) == calls.device_json(server)
    assert "preset" not in calls.device_json(client) and calls.device_json(client)["cable"] is None

    class Duck:                                  # neither a Mapping nor a pydantic model
        def model_dump(self, *, mode="python", exclude=None, exclude_unset=False):
            return {k: v for k, v in {"preset": "x", "mass": 2.0, "damping": 1.0}.items() if k not in (exclude or ())}

    assert calls.stability(Duck()).json == {"device": {"mass": 2.0, "damping": 1.0}}


def test_pydantic_parts_send_only_what_was_set():
    from service.schemas.design_stiffness import StiffnessRequirementsIn

    body = calls.design_stiffness({"mass": 1, "damping": 1}, StiffnessRequirementsIn(passivity=True)).json
    assert body["requirements"] == {"passivity": True}


def test_hardware_calls_send_only_the_targets_given():
    body = calls.design_hardware({"preset": "lhifam"}, "delay", force_gain=5.0, points=9).json
    assert body == {"device": {"preset": "lhifam"}, "target": {"force_gain": 5.0}, "free": "delay", "points": 9}
    call = calls.plot_hardware({"preset": "lhifam"}, "mass", stiffness=2e5, apparent_mass=0.5, format="svg")
    assert call.path == "/v1/plots/hardware" and call.params == {"format": "svg"} and call.kind == "plot"
    assert call.json["target"] == {"stiffness": 2e5, "apparent_mass": 0.5}
    assert calls.design_hardware({"preset": "lhifam"}, "delay", stiffness=1.0).kind == "design"


def test_422_names_the_fields_and_is_not_retried():
    detail = [{"type": "greater_than", "loc": ["body", "device", "mass"], "msg": "Input should be greater than 0"},
              {"type": "value_error", "loc": ["body", "requirements", "max_force"], "msg": "required"}]
    zw, rec = client(lambda r: httpx.Response(422, json={"detail": detail}))
    with pytest.raises(ValidationFailed) as info:
        zw.design_stiffness({"mass": -1, "damping": 0})
    assert info.value.fields == ["device.mass", "requirements.max_force"]
    assert "device.mass: Input should be greater than 0" in str(info.value)
    assert len(rec.requests) == 1


@pytest.mark.parametrize("status", [400, 401, 404, 413, 500, 503])
def test_other_statuses_are_api_errors_and_never_retried(status):
    zw, rec = client(lambda r: httpx.Response(status, json={"detail": f"nope {status}"}))
    with pytest.raises(APIError) as info:
        zw.presets()
    assert info.value.status == status and info.value.detail == f"nope {status}"
    assert not isinstance(info.value, ValidationFailed)
    assert len(rec.requests) == 1


def test_a_non_json_error_body_is_kept_as_text():
    zw, _ = client(lambda r: httpx.Response(502, text="Bad Gateway from the proxy"))
    with pytest.raises(APIError, match="Bad Gateway from the proxy"):
        zw.health()


def test_connection_errors_are_retried_then_raised():
    def refuse(request):
        raise httpx.ConnectError("[Errno 111] Connection refused", request=request)
    zw, rec = client(refuse)
    with pytest.raises(TransportError) as info:
        zw.stability({"preset": "lhifam"})
    assert len(rec.requests) == 3 and info.value.attempts == 3


def test_a_connection_that_comes_back_succeeds():
    def flaky(request):
        if len(rec.requests) < 2:
            raise httpx.ConnectTimeout("connect timed out", request=request)
        return httpx.Response(200, json=HEALTH)
    zw, rec = client(flaky)
    assert zw.health().status == "ok" and len(rec.requests) == 2


def test_a_read_timeout_is_not_retried():
    """The server may already be computing: repeating the request could double the work."""
    def slow(request):
        raise httpx.ReadTimeout("read timed out", request=request)
    zw, rec = client(slow)
    with pytest.raises(TransportError, match="ReadTimeout"):
        zw.design_stiffness({"preset": "lhifam"})
    assert len(rec.requests) == 1


def test_backoff_doubles():
    assert [Retries(attempts=4, backoff=0.1).delay(i) for i in (1, 2, 3)] == [0.1, 0.2, 0.4]
    with pytest.raises(ValueError, match="attempts"):
        Retries(attempts=0)


def test_plot_bytes_and_media_type():
    png = b"\x89PNG\r\n\x1a\nrest"
    zw, rec = client(lambda r: httpx.Response(200, content=png, headers={"content-type": "image/png"}))
    plot = zw.plot_boundary({"preset": "lhifam"}, points=10)
    assert plot.content == png and plot.media_type == "image/png"
    assert json.loads(rec.requests[0].content) == {"device": {"preset": "lhifam"}, "points": 10}
    assert rec.requests[0].url.params["format"] == "png"   # every plot route takes ?format= (docs/clients.md)
    zw.plot_simulation({"preset": "lhifam"}, {"experiment": "release"}, format="svg")
    assert rec.requests[1].url.params["format"] == "svg"


def test_async_client_shares_the_behaviour():
    attempts = []

    def handler(request):
        attempts.append(request)
        if request.url.path == "/healthz":
            return httpx.Response(200, json=HEALTH)
        if request.url.path == "/v1/presets":
            raise httpx.ConnectError("refused", request=request)
        return httpx.Response(422, json={"detail": [{"loc": ["body", "device", "delay"], "msg": "bad"}]})

    async def run():
        async with AsyncZwidthClient("http://zw.test", token="t", transport=httpx.MockTransport(handler),
                                     retries=FAST) as az:
            h = await az.health()
            with pytest.raises(TransportError):
                await az.presets()
            with pytest.raises(ValidationFailed) as info:
                await az.stability({"preset": "lhifam", "delay": -1})
            return h, info.value
    h, exc = asyncio.run(run())
    assert h.version == "9.9.9" and exc.fields == ["device.delay"]
    assert [r.url.path for r in attempts] == ["/healthz"] + ["/v1/presets"] * 3 + ["/v1/analysis/stability"]
    assert all(r.headers["authorization"] == "Bearer t" for r in attempts)


def test_from_env(monkeypatch):
    monkeypatch.setenv("ZWIDTH_URL", "http://lab:9000/")
    monkeypatch.setenv("ZWIDTH_API_TOKEN", "abc")
    with ZwidthClient.from_env() as zw:
        assert zw.url == "http://lab:9000" and zw._headers["Authorization"] == "Bearer abc"


def test_study_calls():
    zw, rec = client(lambda r: httpx.Response(200, content=b"<svg/>", headers={"content-type": "image/svg+xml"}))
    plot = zw.plot_study("abc123", "critical_stiffness", "device.delay", format="svg")
    req = rec.requests[0]
    assert req.method == "GET" and req.url.path == "/v1/studies/abc123/plot"
    assert dict(req.url.params) == {"y": "critical_stiffness", "x": "device.delay", "format": "svg"}
    assert plot.media_type == "image/svg+xml"
    for bad in ("", "..", "a/b", "a?b"):
        with pytest.raises(ValueError, match="study_id"):
            calls.plot_study(bad, "y", "x")


def test_study_calls_send_the_contract_requests():
    seen = []

    def answer(r: httpx.Request) -> httpx.Response:
        seen.append(r)
        if r.method == "DELETE" and r.url.params.get("purge") == "true":
            return httpx.Response(204)
        if r.url.params.get("format") == "parquet":
            return httpx.Response(200, content=b"PAR1...", headers={"content-type": "application/vnd.apache.parquet"})
        return httpx.Response(200, json={"studies": [], "offset": 0, "limit": 5})

    zw, _ = client(answer)
    assert zw.studies(limit=5, status="done").studies == []
    assert zw.cancel_study("abc", purge=True) is None
    export = zw.export_study("abc", "parquet")
    assert export.content.startswith(b"PAR1") and export.media_type == "application/vnd.apache.parquet"
    with pytest.raises(ValueError, match="study_id"):
        zw.cancel_study("../x")
    with pytest.raises(ValueError, match="format"):
        zw.export_study("abc", "xlsx")
    assert [(r.method, r.url.path, dict(r.url.params)) for r in seen] == [
        ("GET", "/v1/studies", {"limit": "5", "status": "done"}),
        ("DELETE", "/v1/studies/abc", {"purge": "true"}),
        ("GET", "/v1/studies/abc/results", {"format": "parquet"})]
