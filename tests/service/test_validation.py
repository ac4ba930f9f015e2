"""Every bad input answers 422 naming the field and the rule (413 for an oversized body); never 500."""

from __future__ import annotations

import json

import pytest

from models.device import MAX_DELAY_SAMPLES
from optim.stability.analysis import MAX_GRID_POINTS
from optim.stability.boundary import MAX_BOUNDARY_POINTS
from service.cost import REFERENCE_REQUEST_BUDGET_DELAY_SAMPLES

from .conftest import LHIFAM_RIGID, make_client

STABILITY = "/v1/analysis/stability"
JSON = {"content-type": "application/json"}
CABLE = {"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.1, "body_damping": 3.4,
         "stiffness": 79500.0, "damping": 15.0}


def errors(r) -> list[dict]:
    assert r.status_code == 422, (r.status_code, r.text)
    detail = r.json()["detail"]
    assert isinstance(detail, list) and detail
    for e in detail:
        assert {"loc", "msg", "type"} <= set(e)
    return detail


def locs(r) -> list[list]:
    return [e["loc"] for e in errors(r)]


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity", "1e400", "-1e400"])
@pytest.mark.parametrize("field", ["mass", "damping", "sample_time", "delay"])
def test_non_finite_json_literals_are_422_naming_the_field(client, literal, field):
    device = {**LHIFAM_RIGID, field: "@@"}
    text = json.dumps({"device": device}).replace('"@@"', literal)
    r = client.post(STABILITY, content=text, headers=JSON)
    assert ["body", "device", field] in locs(r)
    json.loads(r.text)  # the body itself is strict JSON (no NaN echoed)


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "1e400"])
def test_non_finite_controller_is_422(client, literal):
    text = '{"device": {"mass": 5.4, "damping": 3.5}, "controller": {"stiffness": %s}}' % literal
    assert ["body", "controller", "stiffness"] in locs(client.post(STABILITY, content=text, headers=JSON))


def test_unknown_preset_names_the_field_and_lists_the_presets(client):
    r = client.post(STABILITY, json={"device": {"preset": "phantom-9"}})
    (e,) = errors(r)
    assert e["loc"] == ["body", "device", "preset"]
    assert "unknown preset" in e["msg"] and "lhifam" in e["msg"]


@pytest.mark.parametrize("field,value,rule", [
    ("mass", 6.0, "motor_mass + body_mass"),
    ("damping", 1.0, "motor_damping + body_damping"),
])
def test_cable_block_inconsistent_with_mass_or_damping(client, field, value, rule):
    device = {"mass": 5.4, "damping": 3.5, "cable": CABLE, field: value}
    (e,) = errors(client.post(STABILITY, json={"device": device}))
    assert e["loc"] == ["body", "device", field] and rule in e["msg"]


def test_consistent_cable_block_with_sums_given_is_accepted(client):
    r = client.post(STABILITY, json={"device": {"mass": 5.4, "damping": 3.5, "cable": CABLE}})
    assert r.status_code == 200, r.text


def test_delay_beyond_the_cost_limit(client):
    device = {**LHIFAM_RIGID, "delay": (MAX_DELAY_SAMPLES + 1) * 0.001}
    (e,) = errors(client.post(STABILITY, json={"device": device}))
    assert e["loc"] == ["body", "device", "delay"] and str(MAX_DELAY_SAMPLES) in e["msg"]


@pytest.mark.slow
def test_delay_at_the_cost_limit_is_served(client):
    device = {**LHIFAM_RIGID, "delay": MAX_DELAY_SAMPLES * 0.001}
    assert client.post(STABILITY, json={"device": device}).status_code == 200


def test_reference_rung_beyond_its_cost_limit(client):
    device = {**LHIFAM_RIGID, "delay": (REFERENCE_REQUEST_BUDGET_DELAY_SAMPLES + 1) * 0.001}
    (e,) = errors(client.post(STABILITY, json={"device": device, "method": "reference"}))
    assert e["loc"] == ["body", "method"] and str(REFERENCE_REQUEST_BUDGET_DELAY_SAMPLES) in e["msg"]


@pytest.mark.parametrize("path,body,loc", [
    (STABILITY, {"device": LHIFAM_RIGID, "method": "grid", "grid_points": MAX_GRID_POINTS + 1}, ["body", "grid_points"]),
    (STABILITY, {"device": LHIFAM_RIGID, "method": "magic"}, ["body", "method"]),
    (STABILITY, {"device": LHIFAM_RIGID, "controller": {"stiffness": 0}}, ["body", "controller", "stiffness"]),
    (STABILITY, {"device": LHIFAM_RIGID, "controller": {"stiffness": 1, "damping": -1}}, ["body", "controller", "damping"]),
    (STABILITY, {"device": {**LHIFAM_RIGID, "mass": -1}}, ["body", "device", "mass"]),
    (STABILITY, {"device": {**LHIFAM_RIGID, "sample_time": 0}}, ["body", "device", "sample_time"]),
    (STABILITY, {"device": {**LHIFAM_RIGID, "colour": "red"}}, ["body", "device", "colour"]),
    (STABILITY, {"device": LHIFAM_RIGID, "extra": 1}, ["body", "extra"]),
    (STABILITY, {"device": {"damping": 1}}, ["body", "device", "mass"]),
    (STABILITY, {}, ["body", "device"]),
    ("/v1/analysis/boundary", {"device": LHIFAM_RIGID, "points": MAX_BOUNDARY_POINTS + 1}, ["body", "points"]),
    ("/v1/analysis/boundary", {"device": LHIFAM_RIGID, "points": 1}, ["body", "points"]),
    ("/v1/analysis/boundary", {"device": LHIFAM_RIGID, "damping_max": 0}, ["body", "damping_max"]),
    ("/v1/plots/bode", {"device": LHIFAM_RIGID, "format": "gif"}, ["body", "format"]),
    ("/v1/plots/bode", {"device": LHIFAM_RIGID, "points": 5}, ["body", "points"]),
    ("/v1/plots/boundary", {"device": LHIFAM_RIGID, "format": "jpeg"}, ["body", "format"]),
])
def test_out_of_range_fields_are_named(client, path, body, loc):
    assert loc in locs(client.post(path, json=body))


def test_numerics_input_error_becomes_422_naming_the_field(client, monkeypatch):
    """The numerics raise InputError(field, rule) for rules only they know; the answer is 422 at that field."""
    import service.routes.analysis as routes
    from optim.errors import InputError

    def refuses(*args, **kwargs):
        raise InputError("damping_max", "this device has no finite B_max; give damping_max")

    monkeypatch.setattr(routes, "analyse_stability", refuses)
    (e,) = errors(client.post(STABILITY, json={"device": LHIFAM_RIGID}))
    assert e["loc"] == ["body", "damping_max"] and e["msg"].startswith("this device has no finite B_max")


@pytest.mark.slow
def test_an_untyped_value_error_is_never_parsed_for_a_field(client, monkeypatch):
    """Text that looks like "field: rule" in a plain ValueError names no field (only InputError does)."""
    import service.routes.analysis as routes

    def refuses(*args, **kwargs):
        raise ValueError("damping_max: this device has no finite B_max; give damping_max")

    monkeypatch.setattr(routes, "analyse_stability", refuses)
    (e,) = errors(client.post(STABILITY, json={"device": LHIFAM_RIGID}))
    assert e["loc"] == ["body", "device"]


def test_numerics_value_error_without_a_field_name_is_422_on_the_device(client, monkeypatch):
    import service.routes.analysis as routes

    def refuses(*args, **kwargs):
        raise ValueError("Something odd. With a sentence: and more")

    monkeypatch.setattr(routes, "analyse_stability", refuses)
    (e,) = errors(client.post(STABILITY, json={"device": LHIFAM_RIGID}))
    # the numerics' own text stays in the log (it names internals); the answer names the field and a fixed rule
    assert e["loc"] == ["body", "device"] and "Something odd" not in e["msg"]
    assert e["msg"].startswith("the numbers defeat double-precision arithmetic") and "ValueError" in e["msg"]


@pytest.mark.parametrize("text", ['{"device": {"mass": 1', '{"device": }', "[1, 2", "nul", '{"a": 1}}'])
def test_malformed_json_is_422(client, text):
    (e,) = errors(client.post(STABILITY, content=text, headers=JSON))
    assert e["type"] == "json_invalid" and e["loc"][0] == "body"


def test_body_that_is_not_utf8_is_422(client):
    (e,) = errors(client.post(STABILITY, content=b'{"device": "\xff\xfe"}', headers=JSON))
    assert e["type"] == "json_invalid"


def test_body_in_another_charset_is_415(client):
    """A UTF-16 BOM (the JSON parser would read the body as UTF-16; issue 28): 415, not parsed."""
    r = client.post(STABILITY, content=b'\xff\xfe{"device": 1}', headers=JSON)
    assert r.status_code == 415 and "UTF-8" in r.json()["detail"]


@pytest.mark.parametrize("content_type", ["text/plain", "application/x-www-form-urlencoded", "application/xml",
                                          "multipart/form-data; boundary=x", "application/octet-stream"])
def test_wrong_content_type_is_422_naming_the_header(client, content_type):
    body = json.dumps({"device": LHIFAM_RIGID}).encode()
    (e,) = errors(client.post(STABILITY, content=body, headers={"content-type": content_type}))
    assert e["loc"] == ["header", "content-type"] and "application/json" in e["msg"]


def test_missing_content_type_is_422(client):
    r = client.post(STABILITY, content=json.dumps({"device": LHIFAM_RIGID}).encode(),
                    headers={"content-type": ""})
    assert errors(r)


def test_binary_body_with_wrong_content_type_does_not_crash_the_echo(client):
    r = client.post(STABILITY, content=bytes(range(256)) * 10, headers={"content-type": "application/octet-stream"})
    assert errors(r)


def test_json_subtype_is_accepted(client):
    r = client.post(STABILITY, content=json.dumps({"device": LHIFAM_RIGID}),
                    headers={"content-type": "application/vnd.zwidth+json; charset=utf-8"})
    assert r.status_code == 200, r.text


def test_oversized_body_with_content_length_is_413(client):
    r = client.post(STABILITY, content=b"x" * 1_000_001, headers=JSON)
    assert r.status_code == 413
    assert "1000000 bytes" in r.json()["detail"] and "ZWIDTH_MAX_BODY_BYTES" in r.json()["detail"]


def test_oversized_streamed_body_is_413_without_reading_it_all():
    """A chunked body (no Content-Length) is counted as it streams and refused as it passes the limit.

    Driven at the ASGI level: TestClient reads the whole body before calling the app, so it cannot show
    how much the middleware read (the live-server test shows it over a socket).
    """
    import asyncio

    from service.middleware import BodyLimitMiddleware

    pulled = []
    sent: list[dict] = []
    app_called = []

    async def receive():
        pulled.append(1)
        return {"type": "http.request", "body": b" " * 100_000, "more_body": len(pulled) < 100}  # 10 MB in all

    async def send(message):
        sent.append(message)

    async def app(scope, receive, send):  # pragma: no cover - must not be reached
        app_called.append(1)

    scope = {"type": "http", "method": "POST", "path": STABILITY, "headers": [(b"transfer-encoding", b"chunked")]}
    asyncio.run(BodyLimitMiddleware(app, max_body_bytes=250_000)(scope, receive, send))
    assert sent[0]["status"] == 413 and (b"connection", b"close") in sent[0]["headers"]
    assert len(pulled) == 3  # 300 kB read, the limit passed, the other 9.7 MB never read
    assert not app_called


def test_declared_oversized_body_is_413_before_reading_any_of_it():
    import asyncio

    from service.middleware import BodyLimitMiddleware

    pulled, sent = [], []

    async def receive():  # pragma: no cover - must not be reached
        pulled.append(1)
        return {"type": "http.request", "body": b"", "more_body": False}

    async def send(message):
        sent.append(message)

    scope = {"type": "http", "method": "POST", "path": STABILITY, "headers": [(b"content-length", b"10000000")]}
    asyncio.run(BodyLimitMiddleware(None, max_body_bytes=1_000_000)(scope, receive, send))
    assert sent[0]["status"] == 413 and not pulled


def test_streamed_body_below_the_limit_is_served():
    body = json.dumps({"device": LHIFAM_RIGID}).encode()
    with make_client(max_body_bytes=10_000) as c:
        r = c.post(STABILITY, content=iter([body[:10], body[10:]]), headers=JSON)
    assert r.status_code == 200, r.text


def test_body_limit_is_configurable():
    body = json.dumps({"device": LHIFAM_RIGID, "method": "exact"})
    with make_client(max_body_bytes=len(body) - 1) as c:
        assert c.post(STABILITY, content=body, headers=JSON).status_code == 413
    with make_client(max_body_bytes=len(body)) as c:
        assert c.post(STABILITY, content=body, headers=JSON).status_code == 200


def test_unknown_route_and_method_are_4xx(client):
    assert client.get("/v1/nothing").status_code == 404
    assert client.get(STABILITY).status_code == 405
