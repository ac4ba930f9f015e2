"""Bearer auth on /v1, open health and docs, CORS off by default, request ids, JSON logs, no leaks."""

from __future__ import annotations

import json
import logging

import pytest

from service.logs import JsonFormatter
from service.settings import Settings

from .conftest import LHIFAM_RIGID, make_client

TOKEN = "s3cret-token-ä"
STABILITY = "/v1/analysis/stability"


@pytest.fixture
def secured():
    with make_client(api_token=TOKEN) as c:
        yield c


def test_missing_token_is_401_with_www_authenticate(secured):
    r = secured.post(STABILITY, json={"device": LHIFAM_RIGID})
    assert r.status_code == 401
    assert r.headers["www-authenticate"].startswith("Bearer")
    assert "missing bearer token" in r.json()["detail"]


@pytest.mark.slow
@pytest.mark.parametrize("header", [f"Bearer {TOKEN}x", "Bearer s3cret", f"Basic {TOKEN}", f"bearer  {TOKEN[:-1]}",
                                    "Bearer", "", TOKEN])
def test_wrong_token_is_401(secured, header):
    r = secured.post(STABILITY, json={"device": LHIFAM_RIGID}, headers={"authorization": header.encode()})
    assert r.status_code == 401
    assert r.headers["www-authenticate"].startswith("Bearer")
    assert TOKEN not in r.text


def test_right_token_is_accepted_on_every_v1_route(secured):
    auth = {"authorization": f"Bearer {TOKEN}".encode()}
    assert secured.get("/v1/presets", headers=auth).status_code == 200
    assert secured.post(STABILITY, json={"device": LHIFAM_RIGID}, headers=auth).status_code == 200
    assert secured.get("/v1/presets").status_code == 401
    assert secured.post("/v1/plots/bode", json={"device": LHIFAM_RIGID}).status_code == 401


def test_auth_is_checked_before_the_body_is_judged(secured):
    assert secured.post(STABILITY, json={"nonsense": 1}).status_code == 401


@pytest.mark.parametrize("path", ["/healthz", "/docs", "/redoc", "/openapi.json", "/favicon.ico",
                                  "/static-docs/swagger-ui.css"])
def test_health_and_docs_stay_open(secured, path):
    assert secured.get(path).status_code == 200


def test_every_v1_operation_declares_the_bearer_scheme_when_auth_is_on(secured):
    schema = secured.get("/openapi.json").json()
    assert "bearer" in schema["components"]["securitySchemes"]
    for path, ops in schema["paths"].items():
        for op in ops.values():
            if path.startswith("/v1/"):
                assert op.get("security") == [{"bearer": []}], path
                assert "401" in op["responses"]
            else:
                assert "security" not in op, path


def test_token_file(tmp_path):
    f = tmp_path / "token"
    f.write_text(TOKEN + "\n", encoding="utf-8")
    with make_client(api_token_file=f) as c:
        assert c.get("/v1/presets").status_code == 401
        assert c.get("/v1/presets", headers={"authorization": f"Bearer {TOKEN}".encode()}).status_code == 200


def test_empty_or_unreadable_token_file_refuses_to_start(tmp_path):
    empty = tmp_path / "empty"
    empty.write_text("\n")
    with pytest.raises(ValueError, match="api_token_file"):
        Settings(api_token_file=empty)
    with pytest.raises(ValueError, match="api_token_file"):
        Settings(api_token_file=tmp_path / "missing")
    with pytest.raises(ValueError, match="api_token"):
        Settings(api_token="")


def test_settings_from_environment(monkeypatch):
    monkeypatch.setenv("ZWIDTH_API_TOKEN", "abc")
    monkeypatch.setenv("ZWIDTH_MAX_BODY_BYTES", "1234")
    monkeypatch.setenv("ZWIDTH_REQUEST_TIMEOUT", "2.5")
    monkeypatch.setenv("ZWIDTH_CORS_ORIGINS", "https://a.example, https://b.example")
    s = Settings()
    assert (s.token, s.max_body_bytes, s.request_timeout) == ("abc", 1234, 2.5)
    assert s.cors_origins == ["https://a.example", "https://b.example"]
    assert "abc" not in repr(s)  # a secret never shows in logs or tracebacks


def test_cors_is_off_by_default(client):
    r = client.options(STABILITY, headers={"origin": "https://evil.example", "access-control-request-method": "POST"})
    assert "access-control-allow-origin" not in r.headers
    r = client.get("/healthz", headers={"origin": "https://evil.example"})
    assert "access-control-allow-origin" not in r.headers


def test_cors_allows_only_configured_origins():
    with make_client(cors_origins=["https://lab.example"]) as c:
        ok = c.options(STABILITY, headers={"origin": "https://lab.example", "access-control-request-method": "POST"})
        assert ok.status_code == 200 and ok.headers["access-control-allow-origin"] == "https://lab.example"
        bad = c.options(STABILITY, headers={"origin": "https://evil.example", "access-control-request-method": "POST"})
        assert bad.headers.get("access-control-allow-origin") != "https://evil.example"


def test_request_id_is_echoed_or_generated(client):
    r = client.get("/healthz", headers={"x-request-id": "lab-42.a"})
    assert r.headers["x-request-id"] == "lab-42.a"
    generated = client.get("/healthz").headers["x-request-id"]
    assert len(generated) == 32 and generated != client.get("/healthz").headers["x-request-id"]
    # An unsafe id (spaces, overlong) is replaced, not echoed into headers and logs.
    assert client.get("/healthz", headers={"x-request-id": "a b"}).headers["x-request-id"] != "a b"
    assert len(client.get("/healthz", headers={"x-request-id": "x" * 500}).headers["x-request-id"]) == 32


def test_error_answers_carry_the_request_id_too(client):
    r = client.post(STABILITY, content=b"x" * 2_000_000, headers={"content-type": "application/json",
                                                                  "x-request-id": "big-1"})
    assert r.status_code == 413 and r.headers["x-request-id"] == "big-1"


class _Collect(logging.Handler):
    def __init__(self):
        super().__init__()
        self.lines: list[str] = []
        self.setFormatter(JsonFormatter())

    def emit(self, record):
        self.lines.append(self.format(record))


def test_access_log_is_one_json_line_with_the_request_id(client):
    handler = _Collect()
    logger = logging.getLogger("zwidth.access")
    logger.addHandler(handler)
    try:
        client.post(STABILITY, json={"device": LHIFAM_RIGID}, headers={"x-request-id": "trace-7"})
    finally:
        logger.removeHandler(handler)
    (line,) = handler.lines
    entry = json.loads(line)
    assert entry["request_id"] == "trace-7" and entry["status"] == 200
    assert entry["method"] == "POST" and entry["path"] == STABILITY and entry["duration_ms"] > 0
    assert entry["level"] == "info" and entry["logger"] == "zwidth.access"


def test_unexpected_errors_leak_no_trace_or_path(client, monkeypatch):
    import service.routes.analysis as routes

    def broken(*args, **kwargs):
        raise KeyError("/work/secret/path.py line 12")

    monkeypatch.setattr(routes, "analyse_stability", broken)
    r = client.post(STABILITY, json={"device": LHIFAM_RIGID}, headers={"x-request-id": "oops-1"})
    assert r.status_code == 500
    assert r.json() == {"detail": "internal error", "request_id": "oops-1"}
    assert "secret" not in r.text and "Traceback" not in r.text
    assert r.headers["x-request-id"] == "oops-1"  # the operator can find the traceback in the log by it


def test_unexpected_value_error_without_a_field_is_500_without_leaks(client, monkeypatch):
    from pydantic import BaseModel

    import service.routes.analysis as routes

    class Inner(BaseModel):
        x: int

    def broken(*args, **kwargs):
        Inner(x="not a number at /work/secret")  # a pydantic ValidationError: a ValueError, but a bug here

    monkeypatch.setattr(routes, "analyse_stability", broken)
    r = client.post(STABILITY, json={"device": LHIFAM_RIGID})
    assert r.status_code == 500 and r.json() == {"detail": "internal error", "request_id": r.headers["x-request-id"]}
