"""Input that used to answer 500, or that was read laxly, on every route (issue 18 "500 from input", issue 17
"Lax numbers" and "Absurd paging", issue 19 "Errors carry their field").

Every numeric field of every request body is found in the OpenAPI schema itself, so a new field is covered
without editing this file.  In-process (TestClient); tests/service/test_live_abuse.py replays the same
reproducers against a real uvicorn.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any, Iterator

import pytest

from service.app import create_app
from service.body_guard import MAX_JSON_DEPTH, json_depth, lone_surrogate_field
from service.errors import MAX_ECHO_CHARS
from service.settings import Settings

from .conftest import LHIFAM_RIGID

JSON = {"content-type": "application/json"}
_STORE = Path(tempfile.mkdtemp(prefix="zwidth-abuse-")) / "studies.db"


@pytest.fixture(scope="module")
def client():
    from fastapi.testclient import TestClient

    app = create_app(Settings(prestart_workers=False, access_log=False, database_url=f"sqlite:///{_STORE}"))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


@pytest.fixture(scope="module")
def spec(client) -> dict:
    return client.get("/openapi.json").json()


def _resolve(spec: dict, node: dict) -> dict:
    while "$ref" in node:
        node = spec["components"]["schemas"][node["$ref"].rsplit("/", 1)[1]]
    return node


def body_operations(spec: dict) -> Iterator[tuple[str, dict, dict]]:
    """(path, request schema, first example body) of every operation with a JSON body."""
    for path, ops in spec["paths"].items():
        op = ops.get("post")
        if not op or "requestBody" not in op:
            continue
        media = op["requestBody"]["content"]["application/json"]
        schema = _resolve(spec, media["schema"])
        examples = [e["value"] for e in media.get("examples", {}).values()] or schema.get("examples") or []
        assert examples, f"{path}: the request schema has no example to start from"
        yield path, schema, examples[0]


def numeric_fields(spec: dict, schema: dict, body: Any, at: tuple = ()) -> Iterator[tuple[tuple, str]]:
    """(path, "number" | "integer") of every numeric property reachable in ``body``'s objects (the parents must
    exist in the example; models.device's and models.simulation.scene's blocks are reached through the example's)."""
    schema = _resolve(spec, schema)
    for alt in schema.get("anyOf", []) + schema.get("allOf", []):
        yield from numeric_fields(spec, alt, body, at)
    if not isinstance(body, dict):
        return
    for name, prop in schema.get("properties", {}).items():
        prop = _resolve(spec, prop)
        kinds = {prop.get("type")} | {_resolve(spec, a).get("type") for a in prop.get("anyOf", [])}
        if "integer" in kinds:
            yield at + (name,), "integer"
        elif "number" in kinds:
            yield at + (name,), "number"
        if name in body:
            yield from numeric_fields(spec, prop, body[name], at + (name,))


def _with(body: dict, path: tuple, value: Any) -> dict:
    out = json.loads(json.dumps(body))
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


def _cases(client, spec) -> list[tuple[str, dict, tuple, str]]:
    out = []
    for route, schema, example in body_operations(spec):
        seen = set()
        for path, kind in numeric_fields(spec, schema, example):
            if path not in seen:
                seen.add(path)
                out.append((route, example, path, kind))
    return out


def _locs(r) -> list[list]:
    assert r.status_code == 422, (r.status_code, r.text[:300])
    return [e["loc"] for e in r.json()["detail"]]


@pytest.mark.slow
def test_every_numeric_field_of_every_route_takes_json_numbers_only(client, spec):
    """true, "5.4" (and 5.5 for an integer) are refused with a 422 at the field, on every route."""
    cases = _cases(client, spec)
    routes = {c[0] for c in cases}
    assert len(cases) >= 60 and len(routes) >= 12, (len(cases), sorted(routes))
    for route, example, path, kind in cases:
        bad = [True, "5.4"] + ([5.5] if kind == "integer" else [])
        for value in bad:
            r = client.post(route, json=_with(example, path, value))
            assert ["body", *path] in _locs(r), (route, path, value, r.text[:300])


def test_every_integer_field_has_an_upper_bound(client, spec):
    """A 38-digit integer in any integer body field is a 422 at that field (never an OverflowError)."""
    n = 0
    for route, example, path, kind in _cases(client, spec):
        if kind == "integer":
            for value in (10**38, -(10**38), 2**63):
                r = client.post(route, json=_with(example, path, value))
                assert ["body", *path] in _locs(r), (route, path, value, r.text[:300])
            n += 1
    assert n >= 10


def test_integers_are_valid_numbers(client):
    """A JSON integer is a valid float: "mass": 5 is 5 kg."""
    r = client.post("/v1/analysis/stability", json={"device": {"mass": 5, "damping": 3, "sample_time": 0.001}})
    assert r.status_code == 200, r.text


@pytest.mark.parametrize("name", ["offset", "limit"])
@pytest.mark.parametrize("value", ["9223372036854775808", "9" * 38, "-1", "1e3", "true"])
def test_paging_integers_are_422_naming_the_parameter(client, name, value):
    r = client.get(f"/v1/studies?{name}={value}")
    assert ["query", name] in _locs(r)
    sid = client.post("/v1/studies", json={"problem": "stability", "base": {"device": LHIFAM_RIGID},
                                           "sweep": {"device.delay": [0.0]}}).json()["id"]
    r = client.get(f"/v1/studies/{sid}/results?{name}={value}")
    assert ["query", name] in _locs(r)


def test_largest_offset_pages_past_the_end(client):
    r = client.get(f"/v1/studies?offset={2**53 - 1}")
    assert r.status_code == 200 and r.json()["studies"] == []


def test_lax_numbers_in_a_study_base_are_refused(client):
    for device, loc in [({**LHIFAM_RIGID, "mass": True}, "mass"), ({**LHIFAM_RIGID, "damping": "3.5"}, "damping")]:
        r = client.post("/v1/studies", json={"problem": "stability", "base": {"device": device},
                                             "sweep": {"device.delay": [0.0]}})
        assert ["body", "base", "device", loc] in _locs(r), r.text
    r = client.post("/v1/studies", json={"problem": "stiffness", "base": {"device": LHIFAM_RIGID,
                                         "requirements": {"min_gain_margin_db": "6"}}, "sweep": {"device.delay": [0.0]}})
    assert ["body", "base", "requirements", "min_gain_margin_db"] in _locs(r), r.text


def _nested(depth: int, leaf: Any = 1) -> Any:
    for _ in range(depth):
        leaf = {"a": leaf}
    return leaf


def _raw(client, route: str, text: str):
    return client.post(route, content=text.encode(), headers=JSON)


def test_deep_nesting_is_422_naming_the_limit_on_every_route(client, spec):
    for route, _, example in body_operations(spec):
        for depth in (MAX_JSON_DEPTH + 1, 600, 20_000):
            text = json.dumps({**example, "zz_unknown": _nested(depth - 1)}) if depth < 900 else \
                '{"zz": ' + "[" * depth + "]" * depth + "}"
            r = _raw(client, route, text)
            (e,) = r.json()["detail"]
            assert r.status_code == 422 and e["type"] == "json_too_deep" and str(MAX_JSON_DEPTH) in e["msg"], route


def test_free_form_study_objects_nested_deep_are_422(client):
    for where in ("device", "requirements"):
        base = {"device": LHIFAM_RIGID, where: {**({} if where == "requirements" else LHIFAM_RIGID),
                                                 "x": _nested(300)}}
        r = _raw(client, "/v1/studies", json.dumps({"problem": "stability", "base": base,
                                                   "sweep": {"device.delay": [0.0]}}))
        assert r.status_code == 422 and r.json()["detail"][0]["type"] == "json_too_deep"


def test_nesting_at_the_limit_is_an_ordinary_validation_error(client):
    text = json.dumps({"device": LHIFAM_RIGID, "zz": _nested(MAX_JSON_DEPTH - 1)})
    r = _raw(client, "/v1/analysis/stability", text)
    assert ["body", "zz"] in _locs(r)


def test_lone_surrogates_are_422_on_every_route(client, spec):
    for route, _, example in body_operations(spec):
        for s in ('"\\ud800"', '"x\\udfff"', '"\\uDBFF\\u0041"'):
            text = json.dumps({**example, "zz": 1})[:-1] + ', "zz2": ' + s + "}"
            r = _raw(client, route, text)
            assert r.status_code == 422 and r.json()["detail"][0]["type"] == "string_unicode", (route, r.text[:200])
            # issue 29: the 422 names the field, not a byte offset
            assert r.json()["detail"][0]["loc"] == ["body", "zz2"] and "byte" not in r.text, r.text


def test_a_lone_surrogate_is_named_at_its_field_however_deep(client):
    """Issue 29: the 422 named a byte offset.  An escaped backslash before "ud800" and a surrogate pair are fine."""
    text = r'{"device": {"preset": "lhifam", "zz": [1, {"name": "ok \\ud800 \ud83d\ude00 \udc00"}]}}'
    r = _raw(client, "/v1/analysis/stability", text)
    (e,) = r.json()["detail"]
    assert r.status_code == 422 and e["loc"] == ["body", "device", "zz", 1, "name"], r.text
    r = _raw(client, "/v1/analysis/stability", r'{"device": {"\udfff": 1}}')
    assert r.json()["detail"][0]["loc"] == ["body", "device", "\ufffd"], r.text


def test_surrogate_pairs_and_escaped_backslashes_are_fine():
    assert lone_surrogate_field(b'{"a": "\\ud83d\\ude00"}') is None
    assert lone_surrogate_field(b'{"a": "\\\\ud800"}') is None        # a backslash, then "ud800"
    assert lone_surrogate_field(b'{"a": [0, "\\\\\\ud800"]}') == ("a", 1)
    assert json_depth(b'{"a": "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["}') <= 1
    assert json_depth(b"[" * 100 + b'"]]]\\""' + b"]" * 100) == 100


def test_the_422_echo_is_capped(client):
    """A 60k-point push profile used to come back whole (995 kB)."""
    times = list(range(60_000))
    scene = {"experiment": "push", "duration": 1.0, "controller": {"stiffness": 1000},
             "push": {"times": times, "forces": [1] * 59_999, "zz": times}}
    r = client.post("/v1/simulate", json={"device": LHIFAM_RIGID, "scene": scene})
    assert r.status_code == 422
    assert len(r.content) < 20 * MAX_ECHO_CHARS, len(r.content)


def test_numerics_input_error_is_422_with_field_and_rule(client):
    """A rule only the numerics know (optim.domain), raised as InputError, answers 422 at its field."""
    r = client.post("/v1/analysis/stability", json={"device": {"mass": 1e-300, "damping": 0, "sample_time": 1}})
    (e,) = r.json()["detail"]
    assert r.status_code == 422 and e["loc"] == ["body", "device", "mass"] and "mass/sample_time" in e["msg"]
    r = client.post("/v1/analysis/stability", json={"device": {**LHIFAM_RIGID, "delay": 11.0}})
    (e,) = r.json()["detail"]
    assert e["loc"] == ["body", "device", "delay"] and "delay/sample_time ≤ 10000 samples" in e["msg"]


def test_design_input_errors_are_422_not_failed(client):
    """The stiffness design used to answer an input error raised in the numerics with 200 "failed"; now 422
    at the field, as the analyses (optim.domain: a cap of 1e-300 N/m is outside the numeric domain)."""
    r = client.post("/v1/design/stiffness", json={"device": LHIFAM_RIGID, "requirements": {"max_stiffness": 1e-300}})
    assert ["body", "requirements", "max_stiffness"] in _locs(r), r.text


def test_no_route_parses_error_text():
    """Issue 19: the field comes from InputError.field, never from splitting a message."""
    root = Path(__file__).resolve().parents[2]
    hits = [f"{p}:{i}" for d in ("optim", "service") for p in (root / d).rglob("*.py")
            for i, line in enumerate(p.read_text().splitlines(), 1) if 'partition(": ")' in line]
    assert hits == []


def test_no_untyped_field_errors_are_raised_in_the_numerics():
    """A ValueError("field: rule") would answer 500 now (the text is not parsed): raise InputError(field, rule)."""
    import re

    root = Path(__file__).resolve().parents[2]
    pattern = re.compile(r'raise ValueError\(\s*f?"[A-Za-z_{}.\[\]]+: ')
    hits = [f"{p}:{i}" for d in ("optim", "models") for p in (root / d).rglob("*.py")
            for i, line in enumerate(p.read_text().splitlines(), 1) if pattern.search(line)]
    # closed_loop_matrices is a programming error (a caller's misuse), not the client's input.
    assert [h for h in hits if "sim_loop.py" not in h] == []


def _store_error_app(url: str):
    from fastapi.testclient import TestClient

    return TestClient(create_app(Settings(prestart_workers=False, access_log=False, database_url=url)),
                      raise_server_exceptions=False)


@pytest.mark.slow
@pytest.mark.parametrize("url", ["postgresql+psycopg://zw:secret@127.0.0.1:1/zw", "sqlite:////proc/zwidth/none.db"])
def test_an_unreachable_store_answers_a_generic_503_with_a_request_id(url):
    pytest.importorskip("psycopg") if url.startswith("postgresql") else None
    with _store_error_app(url) as c:
        r = c.get("/v1/studies", headers={"x-request-id": "store-1"})
    assert r.status_code == 503, r.text
    body = r.json()
    assert body["request_id"] == "store-1" == r.headers["x-request-id"]
    for leak in ("127.0.0.1", "port", "/proc", "Error", "secret", "psycopg", "sqlite"):
        assert leak not in r.text, (leak, r.text)


@pytest.mark.slow
def test_a_store_failure_while_serving_is_a_generic_503(client, monkeypatch):
    from sqlalchemy.exc import OperationalError

    runner = client.app.state.study_runner

    def down(*a, **k):
        raise OperationalError("SELECT", {}, Exception('connection to server at "10.1.2.3", port 5432 failed'))

    monkeypatch.setattr(runner.store, "list", down)
    r = client.get("/v1/studies")
    assert r.status_code == 503 and "10.1.2.3" not in r.text and r.json()["request_id"] == r.headers["x-request-id"]
